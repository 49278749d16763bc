"""One publisher of /mix (std_msgs/String) for the live-tool tests, reliable or best effort.

``python -m tests.commands.mix_peer reliable|best_effort`` publishes its mode as the data every
50 ms with that reliability; prints ``ready`` once the publisher exists, exits on SIGINT or stdin
closing.
"""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from tests.commands.plain_peer import serve


def main() -> None:
    mode = sys.argv[1]
    rclpy.init()
    node = Node(f"mix_peer_{mode}")
    reliability = (
        ReliabilityPolicy.BEST_EFFORT if mode == "best_effort" else ReliabilityPolicy.RELIABLE
    )
    publisher = node.create_publisher(String, "mix", QoSProfile(depth=10, reliability=reliability))
    node.create_timer(0.05, lambda: publisher.publish(String(data=mode)))
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    serve(executor)


if __name__ == "__main__":
    main()
