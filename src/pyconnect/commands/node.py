"""``pyconnect node list|info``: ros2cli's node verbs.

Exit status: 0 done, 1 no such node, 2 a bad command line, 130 on Ctrl-C.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any, TextIO

from pyconnect.commands.common import Parser
from pyconnect.commands.live_options import add_no_daemon, add_spin_time

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands

__all__ = ["register"]

EXAMPLES = """examples:
  pyconnect node list
  pyconnect node info /talker
"""


def register(commands: Subcommands) -> Subcommands:
    """Add ``node`` and its verbs to the ``pyconnect`` subparsers."""
    node = commands.add_parser(
        "node",
        help="list and inspect nodes of a live ROS graph",
        epilog=EXAMPLES,
    )
    verbs = node.add_subparsers(dest="verb", required=True, parser_class=Parser)
    listing = verbs.add_parser("list", help="the nodes of the graph", epilog=EXAMPLES)
    listing.add_argument("-a", "--all", action="store_true", help="also hidden nodes (_name)")
    add_spin_time(listing)
    add_no_daemon(listing)
    listing.set_defaults(run=_list)

    info = verbs.add_parser("info", help="a node's topics, services and actions", epilog=EXAMPLES)
    info.add_argument("node_name", help="full name, e.g. /talker")
    info.add_argument(
        "--include-hidden", action="store_true", help="also hidden topics and services"
    )
    add_spin_time(info)
    add_no_daemon(info)
    info.set_defaults(run=_info)
    return verbs


def _full_name(name: str, namespace: str) -> str:
    return f"{namespace.rstrip('/')}/{name}"


def _list(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import endpoints_named, graph_session

    with graph_session("node") as session:
        session.spin_for(args.spin_time)
        # The nodes owning the endpoints discovered so far are on their way: wait for them (at
        # most another --spin-time, for endpoints of a DDS program that has no ROS nodes).
        session.spin_until(lambda: endpoints_named(session), args.spin_time)
        nodes = session.node.get_node_names_and_namespaces()
    for name, namespace in sorted(nodes, key=lambda n: _full_name(n[0], n[1])):
        if name.startswith("_") and not args.all:
            continue
        print(_full_name(name, namespace), file=out)
    return 0


def _section(title: str, entries: list[tuple[str, list[str]]], hidden: bool, out: TextIO) -> None:
    print(f"  {title}:", file=out)
    for name, types in sorted(entries):
        if not hidden and any(part.startswith("_") for part in name.split("/")):
            continue
        print(f"    {name}: {', '.join(types)}", file=out)


def _info(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from rclpy.action.graph import (
        get_action_client_names_and_types_by_node,
        get_action_server_names_and_types_by_node,
    )

    from pyconnect.commands.graph import CommandFailed, graph_session, report_failure

    wanted = args.node_name if args.node_name.startswith("/") else f"/{args.node_name}"
    with graph_session("node") as session:
        node = session.node
        match: list[tuple[str, str]] = []

        def known() -> bool:
            match[:] = [
                (name, namespace)
                for name, namespace in node.get_node_names_and_namespaces()
                if _full_name(name, namespace) == wanted
            ]
            return bool(match)

        if not session.spin_until(known, args.spin_time):
            return report_failure(CommandFailed(f"Unable to find node '{wanted}'"), err)
        session.spin_for(min(args.spin_time, 0.5))  # its endpoints follow the node itself
        name, namespace = match[0]
        sections: list[tuple[str, Any]] = [
            ("Subscribers", node.get_subscriber_names_and_types_by_node(name, namespace)),
            ("Publishers", node.get_publisher_names_and_types_by_node(name, namespace)),
            ("Service Servers", node.get_service_names_and_types_by_node(name, namespace)),
            ("Service Clients", node.get_client_names_and_types_by_node(name, namespace)),
            ("Action Servers", get_action_server_names_and_types_by_node(node, name, namespace)),
            ("Action Clients", get_action_client_names_and_types_by_node(node, name, namespace)),
        ]
    print(wanted, file=out)
    for title, entries in sections:
        _section(title, entries, args.include_hidden, out)
    return 0
