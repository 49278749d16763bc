"""The live-graph commands' command-line options, importable without rclpy (the ``ros`` extra).

Building the ``pyconnect`` parser registers every command, so nothing here may import rclpy at
the top: an install without the ``ros`` extra still runs ``--help``, ``bag`` and ``interface``.
rclpy is imported when a live command's command line is read (``expand_name``) or the command
runs (``pyconnect.commands.graph``); ``ros_missing`` turns rclpy being absent then into one line
naming the extra.
"""

from __future__ import annotations

from typing import Any

from pyconnect.commands.argument_types import nonnegative_seconds, positive_int
from pyconnect.commands.common import UsageError

__all__ = [
    "CLI_NODE_NAME",
    "HIDDEN_PREFIX",
    "QOS_DURABILITIES",
    "QOS_HISTORIES",
    "QOS_PROFILES",
    "QOS_RELIABILITIES",
    "ROS_EXTRA_INSTALL",
    "add_no_daemon",
    "add_qos",
    "add_spin_time",
    "expand_name",
    "ros_missing",
]

HIDDEN_PREFIX = "_"
# What ``~`` (the node's private namespace) expands to in a name given on the command line.
CLI_NODE_NAME = f"{HIDDEN_PREFIX}pyconnect_cli"
# The presets --qos-profile takes: rclpy's ``QoSPresetProfiles.short_keys()`` but "unknown", a
# placeholder rmw refuses. Written out because the parser is built without rclpy; a test keeps
# it equal to rclpy's list.
QOS_PROFILES = (
    "default",
    "system_default",
    "sensor_data",
    "services_default",
    "parameters",
    "parameter_events",
    "action_status_default",
    "best_available",
)
# The policies --qos-reliability, --qos-durability and --qos-history take: rclpy's short keys
# but "unknown", as for the presets (a test keeps them equal to rclpy's).
QOS_RELIABILITIES = ("system_default", "reliable", "best_effort", "best_available")
QOS_DURABILITIES = ("system_default", "transient_local", "volatile", "best_available")
QOS_HISTORIES = ("system_default", "keep_last", "keep_all")
ROS_EXTRA_INSTALL = "pip install 'pyconnect-ros[ros]'"


def ros_missing(error: ImportError) -> UsageError | None:
    """The one-line error for a live command run where rclpy cannot be imported, or None when
    ``error`` is about another module (a bug to be shown with its traceback)."""
    if not isinstance(error, ModuleNotFoundError) or error.name is None:
        return None
    if error.name.split(".")[0] != "rclpy":
        return None
    return UsageError(
        f"this command talks to a live ROS 2 graph and needs rclpy ({error}): "
        f"{ROS_EXTRA_INSTALL}, or source a ROS 2 Jazzy install"
    )


def expand_name(name: str) -> str:
    """A topic, service or action name as rclpy resolves it: ``chatter`` → ``/chatter``.

    The graph lists full names only, so a relative name must be expanded before it is looked
    up (``ros2`` does the same; a publisher's node would expand it itself). Also an argparse
    ``type``: a name rcl refuses is a bad command line (``UsageError``, exit status 2).
    """
    # rcl's own expansion and validation, so a name means what it means to every other node.
    from rclpy.exceptions import InvalidTopicNameException
    from rclpy.expand_topic_name import expand_topic_name
    from rclpy.validate_full_topic_name import validate_full_topic_name

    try:
        full: str = expand_topic_name(name, CLI_NODE_NAME, "/")
        validate_full_topic_name(full)  # expansion lets some through: '/a//b'
    except ValueError as error:
        # rcl appends where in its C source it failed: no use to the user.
        raise UsageError(str(error).split(", at /")[0]) from None
    except InvalidTopicNameException as error:
        # Its message points at the fault on two more lines; one line names the name instead.
        raise UsageError(f"{str(error).splitlines()[0]} {full!r}") from None
    return full


def add_qos(parser: Any, *, default: str = "one that matches the publishers") -> None:
    """ros2cli's QoS options: ``--qos-profile NAME`` (a preset), and ``--qos-depth``,
    ``--qos-history``, ``--qos-reliability``, ``--qos-durability`` overriding one policy of it
    (pyconnect.commands.live_qos reads them); ``default`` says what is used without them."""
    parser.add_argument(
        "--qos-profile",
        metavar="NAME",
        choices=QOS_PROFILES,
        help=f"a preset profile: {', '.join(QOS_PROFILES)} (default: {default})",
    )
    parser.add_argument(
        "--qos-depth",
        metavar="N",
        type=positive_int,
        help="the queue size (overrides the profile's)",
    )
    parser.add_argument(
        "--qos-history",
        choices=QOS_HISTORIES,
        help="the history policy (overrides the profile's)",
    )
    parser.add_argument(
        "--qos-reliability",
        choices=QOS_RELIABILITIES,
        help="the reliability policy (overrides the profile's)",
    )
    parser.add_argument(
        "--qos-durability",
        choices=QOS_DURABILITIES,
        help="the durability policy (overrides the profile's; transient_local: latched)",
    )


def add_no_daemon(parser: Any) -> None:
    """``--no-daemon``: taken and ignored, so ros2 command lines carry over. pyconnect has no
    daemon: every command discovers the graph itself, as ros2's do with this flag."""
    parser.add_argument(
        "--no-daemon",
        action="store_true",
        help="accepted for ros2 scripts; pyconnect never uses a daemon",
    )


def add_spin_time(parser: Any, default: float = 2.0) -> None:
    """``--spin-time S``: how long to discover the graph before answering (ros2cli's name).

    Seconds from 0 to a ROS duration's longest, as the other numeric options: ``nan`` or a
    negative number answered at once without discovering anything, ``inf`` never answered."""
    parser.add_argument(
        "--spin-time",
        type=nonnegative_seconds,
        default=default,
        metavar="S",
        help=f"seconds to wait for discovery before answering (default {default})",
    )
