"""``pyconnect action list|info|send_goal``: ros2cli's action verbs with natural values.

Exit status: 0 the goal finished (whatever its status, as ``ros2 action send_goal``), 1 the
command could not do its work (no server, goal rejected, no result within ``--timeout``), 2 a
bad command line, 130 on Ctrl-C. A goal given up on, by Ctrl-C or the timeout, is cancelled
first: the server would otherwise go on executing a goal nobody waits for.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import argparse
import uuid
from typing import TYPE_CHECKING, Any, TextIO

from pyconnect.commands.argument_types import nonnegative_seconds
from pyconnect.commands.common import Parser
from pyconnect.commands.live_options import add_no_daemon, add_spin_time, expand_name

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands

__all__ = ["register"]

EXAMPLES = """examples:
  pyconnect action list -t
  pyconnect action info /fibonacci -t
  pyconnect action send_goal /fibonacci test_msgs/action/Fibonacci "{order: 5}" --feedback
"""

CANCEL_WAIT = 5.0
"""Seconds a cancelled goal's server is given to answer the cancel request before the command
ends anyway (a server that is gone never answers)."""

_STATUS = {
    0: "UNKNOWN",
    1: "ACCEPTED",
    2: "EXECUTING",
    3: "CANCELING",
    4: "SUCCEEDED",
    5: "CANCELED",
    6: "ABORTED",
}


def register(commands: Subcommands) -> Subcommands:
    """Add ``action`` and its verbs to the ``pyconnect`` subparsers."""
    action = commands.add_parser(
        "action",
        help="list actions and send goals on a live ROS graph",
        epilog=EXAMPLES,
    )
    verbs = action.add_subparsers(dest="verb", required=True, parser_class=Parser)
    listing = verbs.add_parser("list", help="the actions of the graph", epilog=EXAMPLES)
    listing.add_argument("-t", "--show-types", action="store_true", help="show each type")
    add_spin_time(listing)
    add_no_daemon(listing)
    listing.set_defaults(run=_list)

    info = verbs.add_parser("info", help="the clients and servers of an action", epilog=EXAMPLES)
    info.add_argument("action_name", type=expand_name)
    info.add_argument("-t", "--show-types", action="store_true", help="show each one's type")
    info.add_argument(
        "-c", "--count", action="store_true", help="only the numbers of clients and servers"
    )
    add_spin_time(info)
    add_no_daemon(info)
    info.set_defaults(run=_info)

    send = verbs.add_parser(
        "send_goal",
        help="send a goal (YAML/JSON) and print the result",
        epilog=EXAMPLES,
    )
    send.add_argument("action_name", type=expand_name)
    send.add_argument("action_type", help="e.g. test_msgs/action/Fibonacci")
    send.add_argument("goal", help="the goal's fields or natural value")
    send.add_argument("-f", "--feedback", action="store_true", help="print the feedback")
    send.add_argument(
        "--timeout",
        type=nonnegative_seconds,
        default=None,
        metavar="S",
        help="give up waiting after S s",
    )
    send.set_defaults(run=_send_goal)
    return verbs


def _list(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from rclpy.action import get_action_names_and_types

    from pyconnect.commands.graph import graph_session

    with graph_session("action") as session:
        session.spin_for(args.spin_time)
        actions = get_action_names_and_types(session.node)
    for name, types in sorted(actions):
        print(f"{name} [{', '.join(types)}]" if args.show_types else name, file=out)
    return 0


def _info(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from rclpy.action.graph import (
        get_action_client_names_and_types_by_node,
        get_action_server_names_and_types_by_node,
    )

    from pyconnect.commands.graph import endpoints_named, graph_session

    clients: list[tuple[str, list[str]]] = []
    servers: list[tuple[str, list[str]]] = []
    with graph_session("action") as session:
        session.spin_for(args.spin_time)
        # An action's clients and servers are found by their nodes, named after their endpoints.
        session.spin_until(lambda: endpoints_named(session), args.spin_time)
        node = session.node
        for name, namespace in node.get_node_names_and_namespaces():
            full = f"{namespace.rstrip('/')}/{name}"
            for found, by_node in (
                (clients, get_action_client_names_and_types_by_node),
                (servers, get_action_server_names_and_types_by_node),
            ):
                found.extend(
                    (full, types)
                    for action, types in by_node(node, name, namespace)
                    if action == args.action_name
                )
    # ros2's lines: ros2 action info prints these whether or not the action exists.
    print(f"Action: {args.action_name}", file=out)
    for title, found in (("Action clients", clients), ("Action servers", servers)):
        print(f"{title}: {len(found)}", file=out)
        if args.count:
            continue
        for full, types in sorted(found):
            print(
                f"    {full} [{', '.join(types)}]" if args.show_types else f"    {full}", file=out
            )
    return 0


def _send_goal(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import graph_session, report_failure
    from pyconnect.commands.value_input import message_template
    from pyconnect.errors import PyconnectError
    from pyconnect.ros.interfaces import interface_class
    from pyconnect.ros.race_free_action_client import RaceFreeActionClient

    try:
        action_class = interface_class(args.action_type, kind="action")
        template = message_template(args.goal, action_class.Goal)
    except PyconnectError as error:
        return report_failure(error, err)
    with graph_session("action") as session:
        client = RaceFreeActionClient(session.node, action_class, args.action_name)
        try:
            return _run_goal(args, session, client, template, out=out, err=err)
        finally:
            # Destroying the node leaves an action client's endpoints in the graph (it is no
            # entity of the node's): a later command in this process would list it.
            client.destroy()


def _run_goal(
    args: argparse.Namespace, session: Any, client: Any, template: Any, *, out: TextIO, err: TextIO
) -> int:
    """``send_goal`` once its client exists: wait for the server, send, print what comes."""
    from pyconnect.commands.graph import CommandFailed, report_failure
    from pyconnect.commands.live_values import shown_line

    if not client.server_is_ready():
        print("Waiting for an action server to become available...", file=out, flush=True)
    if not session.spin_until(client.server_is_ready, args.timeout):
        return report_failure(CommandFailed(f"action server {args.action_name} not available"), err)
    goal = template.stamped()  # `now` / `auto`: the time it is sent, not of the wait
    print(f"Sending goal:\n     {shown_line(goal, err)}\n", file=out, flush=True)

    def on_feedback(message: Any) -> None:
        print(f"Feedback:\n    {shown_line(message.feedback, err)}\n", file=out, flush=True)

    sent: Any = client.send_goal_async(
        goal, feedback_callback=on_feedback if args.feedback else None
    )
    if not session.spin_until(sent.done, args.timeout):
        return report_failure(CommandFailed("the goal was neither accepted nor rejected"), err)
    handle = sent.result()
    if not handle.accepted:
        return report_failure(CommandFailed("Goal was rejected."), err)
    print(f"Goal accepted with ID: {uuid.UUID(bytes=bytes(handle.goal_id.uuid)).hex}\n", file=out)
    result: Any = handle.get_result_async()
    try:
        if not session.spin_until(result.done, args.timeout):
            outcome = _cancel(session, handle)
            return report_failure(
                CommandFailed(f"no result within {args.timeout:g} s: {outcome}"), err
            )
    except KeyboardInterrupt:
        _cancel(session, handle)
        raise
    answer = result.result()
    print(f"Result:\n    {shown_line(answer.result, err)}\n", file=out)
    status = _STATUS.get(answer.status, str(answer.status))
    print(f"Goal finished with status: {status}", file=out, flush=True)
    return 0


def _cancel(session: Any, handle: Any) -> str:
    """Cancel the goal of ``handle`` and wait (at most ``CANCEL_WAIT`` s) for the server to
    answer; what became of it, in words."""
    from action_msgs.srv import CancelGoal

    cancel: Any = handle.cancel_goal_async()
    if not session.spin_until(cancel.done, CANCEL_WAIT):
        return f"asked to cancel the goal, the server did not answer within {CANCEL_WAIT:g} s"
    answer = cancel.result()
    if answer is not None and answer.return_code == CancelGoal.Response.ERROR_NONE:
        return "the goal was cancelled"
    code = None if answer is None else answer.return_code
    why = {
        CancelGoal.Response.ERROR_REJECTED: "the server refused",
        CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID: "the server does not know the goal",
        CancelGoal.Response.ERROR_GOAL_TERMINATED: "the goal had just ended",
    }.get(code, f"the server answered {code}")
    return f"cancelling the goal failed: {why}"
