"""``pyconnect service list|type|call``: ros2cli's service verbs with natural values.

Exit status: 0 done, 1 the command could not do its work, 2 a bad command line, 130 on Ctrl-C.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import argparse
import time
from typing import TYPE_CHECKING, Any, TextIO

from pyconnect.commands.argument_types import nonnegative_seconds, positive_float
from pyconnect.commands.common import Parser
from pyconnect.commands.live_options import add_no_daemon, add_spin_time, expand_name

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands

__all__ = ["register"]

EXAMPLES = """examples:
  pyconnect service list -t
  pyconnect service type /set_light
  pyconnect service call /set_light std_srvs/srv/SetBool "{data: true}"
  pyconnect service call /reset std_srvs/srv/Empty
  pyconnect service call /reset std_srvs/srv/Empty --rate 2
"""


def register(commands: Subcommands) -> Subcommands:
    """Add ``service`` and its verbs to the ``pyconnect`` subparsers."""
    service = commands.add_parser(
        "service",
        help="list and call services of a live ROS graph",
        epilog=EXAMPLES,
    )
    verbs = service.add_subparsers(dest="verb", required=True, parser_class=Parser)
    listing = verbs.add_parser("list", help="the services of the graph", epilog=EXAMPLES)
    listing.add_argument("-t", "--show-types", action="store_true", help="show each type")
    listing.add_argument(
        "--include-hidden-services", action="store_true", help="also services with a _ part"
    )
    add_spin_time(listing)
    add_no_daemon(listing)
    listing.set_defaults(run=_list)

    kind = verbs.add_parser("type", help="the type of a service", epilog=EXAMPLES)
    kind.add_argument("service_name", type=expand_name)
    add_spin_time(kind)
    add_no_daemon(kind)
    kind.set_defaults(run=_type)

    call = verbs.add_parser(
        "call",
        help="call a service with a request (YAML/JSON)",
        epilog=EXAMPLES,
    )
    call.add_argument("service_name", type=expand_name)
    call.add_argument("service_type", help="e.g. std_srvs/srv/SetBool")
    call.add_argument("values", nargs="?", default="{}", help="the request (default {})")
    call.add_argument(
        "--timeout",
        type=nonnegative_seconds,
        default=None,
        metavar="S",
        help="give up after S seconds (waiting for the service, then for each response)",
    )
    call.add_argument(
        "-r",
        "--rate",
        type=positive_float,
        metavar="N",
        help="call again N times a second until Ctrl-C (default: once)",
    )
    call.set_defaults(run=_call)
    return verbs


def _list(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import graph_session

    with graph_session("service") as session:
        session.spin_for(args.spin_time)
        services = session.node.get_service_names_and_types()
    for name, types in sorted(services):
        hidden = any(part.startswith("_") for part in name.split("/"))
        if hidden and not args.include_hidden_services:
            continue
        print(f"{name} [{', '.join(types)}]" if args.show_types else name, file=out)
    return 0


def _type(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import CommandFailed, graph_session, report_failure, settle

    with graph_session("service") as session:
        node = session.node

        def types() -> list[str]:
            found: list[str] = dict(node.get_service_names_and_types()).get(args.service_name, [])
            return found

        if not session.spin_until(lambda: bool(types()), args.spin_time):
            return report_failure(CommandFailed(f"Unknown service '{args.service_name}'"), err)
        # Another server of it, of another type, may be discovered a moment later.
        settle(session, types, timeout=args.spin_time)
        found = types()
    for service_type in found:
        print(service_type, file=out)
    return 0


def _call(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import CommandFailed, graph_session, report_failure
    from pyconnect.commands.live_values import shown_line
    from pyconnect.commands.value_input import message_template
    from pyconnect.errors import PyconnectError
    from pyconnect.ros.interfaces import interface_class

    try:
        srv_class = interface_class(args.service_type, kind="srv")
        template = message_template(args.values, srv_class.Request)
    except PyconnectError as error:
        return report_failure(error, err)
    with graph_session("service") as session:
        client = session.node.create_client(srv_class, args.service_name)
        if not client.service_is_ready():
            print("waiting for service to become available...", file=out, flush=True)
        if not session.spin_until(client.service_is_ready, args.timeout):
            return report_failure(CommandFailed(f"service {args.service_name} not available"), err)
        while True:
            began = time.monotonic()
            request = template.stamped()  # `now` / `auto`: the time of the call, not of the wait
            print(f"requester: making request: {shown_line(request, err)}\n", file=out)
            future: Any = client.call_async(request)
            if not session.spin_until(future.done, args.timeout):
                return report_failure(CommandFailed(f"no response from {args.service_name}"), err)
            response = future.result()
            print(f"response:\n{shown_line(response, err)}\n", file=out, flush=True)
            if args.rate is None:
                return 0
            # As ros2: the next call one period after this one began (at once when overdue).
            session.spin_for(max(0.0, began + 1.0 / args.rate - time.monotonic()))
