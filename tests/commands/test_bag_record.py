"""``pyconnect bag record`` subscribes to the topics of service and action parts it is asked for."""

from __future__ import annotations

import io
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from rclpy.serialization import serialize_message
from test_msgs.action import Fibonacci

from pyconnect.commands import bag_record
from pyconnect.record import open_bag
from pyconnect.record.queued_recorder import QueuedRecorder
from pyconnect.record.split_recorder import SplitRecorder


class _Node:
    """What `_subscribe_new` asks of the graph, with the topics `ros2 topic list -t` shows."""

    def __init__(self, topics: list[tuple[str, list[str]]]) -> None:
        self.topics = topics
        self.subscriptions: dict[str, Any] = {}

    def get_topic_names_and_types(self) -> list[tuple[str, list[str]]]:
        return self.topics

    def get_publishers_info_by_topic(self, _topic: str) -> list[Any]:
        return []

    def create_subscription(self, cls: type, topic: str, callback: Any, _qos: Any, **_: Any) -> None:
        self.subscriptions[topic] = (cls, callback)


def test_an_action_feedback_topic_named_explicitly_is_recorded(tmp_path: Path) -> None:
    feedback = "/fib/_action/feedback"
    node = _Node([(feedback, ["test_msgs/action/Fibonacci_FeedbackMessage"]),
                  ("/events", ["test_msgs/srv/BasicTypes_Event"])])  # fmt: skip
    writer = QueuedRecorder(SplitRecorder(tmp_path / "run"))
    out = io.StringIO()
    session: Any = SimpleNamespace(node=node)
    bag_record._subscribe_new(session, writer, {feedback, "/events"}, set(), out)
    assert "skipping" not in out.getvalue()
    cls, callback = node.subscriptions[feedback]
    assert cls is Fibonacci.Impl.FeedbackMessage
    message = Fibonacci.Impl.FeedbackMessage()
    message.feedback.sequence = [1, 1, 2]
    callback(serialize_message(message))
    writer.close()
    with open_bag(tmp_path / "run") as bag:
        values = [m.value for m in bag]
    assert bag.errors == []
    assert [v["feedback"] for v in values] == [{"sequence": [1, 1, 2]}]
