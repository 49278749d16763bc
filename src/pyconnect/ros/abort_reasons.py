"""Why an action goal was aborted, for result types with no string field to carry the text.

rclpy's action protocol has no place for an abort reason: the result message is all a client
gets, and many result types (``test_msgs/action/Fibonacci``) have no string field. A pyconnect
action server therefore also publishes ``diagnostic_msgs/KeyValue`` (key: the goal id in hex,
value: ``"<Exception>: <text>"``) on ``<action>/_action/abort_reason`` just before it aborts,
and a pyconnect action client reads it there. The topic is reliable and transient-local, so a
reason published before the client's subscription matched still arrives. Plain rclpy clients
are unaffected; for them the text stays in the server's log.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Any

from diagnostic_msgs.msg import KeyValue
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

ABORT_REASON_QOS = QoSProfile(
    depth=32,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
REASON_WAIT_SECONDS = 2.0
"""How long a client waits for the reason of an abort it saw in the result (it is sent first)."""

_KEPT = 256


def abort_reason_topic(ros_node: Any, action_name: str) -> str:
    """The reason topic beside the action's own hidden topics: ``action_name`` expanded (node
    namespace, ``~``, substitutions) but not remapped.

    Why not remapped: rcl_action (Jazzy) expands an action's name and then remaps each hidden
    topic and service by its full name, so ``-r fib:=fibonacci`` leaves the action on ``/fib``.
    Remapping the action name here moved only the reason away from the action, and clients
    lost its text. The full name given to ``create_publisher``/``create_subscription`` is still
    remapped by rules naming it, as each hidden name of the action is.
    """
    return f"{ros_node.resolve_topic_name(action_name, only_expand=True)}/_action/abort_reason"


def goal_key(goal_id: Any) -> str:
    """A goal id (``unique_identifier_msgs/UUID``) as hex."""
    return bytes(goal_id.uuid).hex()


class AbortReasonPublisher:
    """Server side: publish the reason of each aborted goal."""

    def __init__(self, ros_node: Any, action_name: str) -> None:
        topic = abort_reason_topic(ros_node, action_name)
        self._publisher = ros_node.create_publisher(KeyValue, topic, ABORT_REASON_QOS)

    def publish(self, goal_id: Any, text: str) -> None:
        self._publisher.publish(KeyValue(key=goal_key(goal_id), value=text))

    def destroy(self, ros_node: Any) -> None:
        ros_node.destroy_publisher(self._publisher)


class AbortReasons:
    """Client side: the reasons received so far, and a way to wait for one."""

    def __init__(self, ros_node: Any, action_name: str) -> None:
        self._reasons: OrderedDict[str, str] = OrderedDict()
        self._waiting: dict[str, threading.Event] = {}
        self._lock = threading.Lock()
        # Its own group: the reason must be received while the agent's result callback waits.
        self._subscription = ros_node.create_subscription(
            KeyValue,
            abort_reason_topic(ros_node, action_name),
            self._on_reason,
            ABORT_REASON_QOS,
            callback_group=MutuallyExclusiveCallbackGroup(),
        )

    def _on_reason(self, msg: Any) -> None:
        with self._lock:
            self._reasons[msg.key] = msg.value
            while len(self._reasons) > _KEPT:
                self._reasons.popitem(last=False)
            waiting = self._waiting.pop(msg.key, None)
        if waiting is not None:
            waiting.set()

    def wait_for_reason(self, goal_id: Any, wait: Any) -> str:
        """The reason for ``goal_id``; ``wait(event, seconds)`` waits for it if not here yet."""
        key = goal_key(goal_id)
        with self._lock:
            if key in self._reasons:
                return self._reasons.pop(key)
            event = self._waiting.setdefault(key, threading.Event())
        wait(event, REASON_WAIT_SECONDS)
        with self._lock:
            self._waiting.pop(key, None)
            return self._reasons.pop(key, "")

    def destroy(self, ros_node: Any) -> None:
        ros_node.destroy_subscription(self._subscription)
