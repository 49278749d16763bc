"""An action server whose goals run until they are cancelled, for the live-tool tests.

``python -m tests.commands.cancel_peer`` serves /endless (test_msgs/action/Fibonacci): each goal
prints ``executing``, runs until a cancel request arrives (which it accepts), then prints
``canceled`` and ends cancelled. Prints ``ready`` once the server exists; exits on SIGINT or
stdin closing.
"""

from __future__ import annotations

import time

import rclpy
from rclpy.action import ActionServer, CancelResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from test_msgs.action import Fibonacci

from tests.commands.plain_peer import serve


def main() -> None:
    rclpy.init()
    node = Node("cancel_peer")

    def on_cancel(_goal: ServerGoalHandle) -> CancelResponse:
        return CancelResponse.ACCEPT  # rclpy's default refuses every cancel request

    def endless(goal: ServerGoalHandle) -> Fibonacci.Result:
        print("executing", flush=True)
        while not goal.is_cancel_requested:  # a peer, not a test: polling is harmless here
            if not rclpy.ok():  # stopped with the goal still running: let the process end
                return Fibonacci.Result()
            time.sleep(0.01)
        goal.canceled()
        print("canceled", flush=True)
        return Fibonacci.Result()

    ActionServer(node, Fibonacci, "endless", endless, cancel_callback=on_cancel)
    executor = MultiThreadedExecutor()
    executor.add_node(node)
    serve(executor)


if __name__ == "__main__":
    main()
