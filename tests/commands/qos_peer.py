"""A plain rclpy process whose topics need more than a default subscription to be heard.

``python -m tests.commands.qos_peer`` publishes /latched (a String published once, transient
local), /best_effort (Float64, best effort), /fib/_action/feedback (an action part's type,
published with a plain publisher) and /multi (String); ``python -m tests.commands.qos_peer
float`` publishes /multi as Float64, so that the topic has two types. It prints ``ready`` once
everything is created and exits on SIGINT or stdin closing.
"""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64, String
from test_msgs.action import Fibonacci

from tests.commands.plain_peer import serve


def _main_topics(node: Node) -> None:
    latched = node.create_publisher(
        String, "latched", QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    )
    latched.publish(String(data="latched hello"))
    best_effort = node.create_publisher(
        Float64, "best_effort", QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    )
    feedback_type = Fibonacci.Impl.FeedbackMessage
    feedback = node.create_publisher(feedback_type, "fib/_action/feedback", 10)
    multi = node.create_publisher(String, "multi", 10)

    def tick() -> None:
        best_effort.publish(Float64(data=1.5))
        feedback.publish(feedback_type(feedback=Fibonacci.Feedback(sequence=[0, 1, 1])))
        multi.publish(String(data="multi"))

    node.create_timer(0.05, tick)


def _float_topics(node: Node) -> None:
    multi = node.create_publisher(Float64, "multi", 10)
    node.create_timer(0.05, lambda: multi.publish(Float64(data=2.5)))


def main() -> None:
    mode = sys.argv[1] if len(sys.argv) > 1 else "main"
    rclpy.init()
    node = Node(f"qos_peer_{mode}")
    (_float_topics if mode == "float" else _main_topics)(node)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    serve(executor)


if __name__ == "__main__":
    main()
