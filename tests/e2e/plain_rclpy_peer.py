"""A ROS 2 program written the usual rclpy way, run as a separate process by the interop tests.

``python plain_rclpy_peer.py MODE`` with MODE one of talker, listener, service_server,
service_client, action_server, action_client. It prints ``READY`` when set up and one line per
result, and ends by itself (clients, listener) or on SIGTERM/SIGINT (servers, talker).
"""

from __future__ import annotations

import sys

import rclpy
from rclpy.action import ActionClient, ActionServer
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import String
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci


def talker(node: Node) -> None:
    publisher = node.create_publisher(String, "chatter", 10)
    count = iter(range(1_000_000))

    def publish() -> None:
        msg = String()
        msg.data = f"hello {next(count)}"
        publisher.publish(msg)

    node.create_timer(0.02, publish)
    print("READY", flush=True)
    rclpy.spin(node)


def listener(node: Node) -> None:
    received: list[str] = []

    def on_message(msg: String) -> None:
        received.append(msg.data)
        print(f"HEARD {msg.data}", flush=True)

    node.create_subscription(String, "chatter", on_message, 10)
    print("READY", flush=True)
    while rclpy.ok() and len(received) < 3:
        rclpy.spin_once(node, timeout_sec=0.1)


def service_server(node: Node) -> None:
    def handle(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        response.success = request.data
        response.message = f"plain rclpy got {request.data}"
        return response

    node.create_service(SetBool, "enable", handle)
    print("READY", flush=True)
    rclpy.spin(node)


def service_client(node: Node) -> None:
    client = node.create_client(SetBool, "enable")
    print("READY", flush=True)
    client.wait_for_service()
    request = SetBool.Request()
    request.data = True
    future = client.call_async(request)
    rclpy.spin_until_future_complete(node, future)
    response = future.result()
    print(f"RESPONSE {response.success} {response.message}", flush=True)


def action_server(node: Node) -> None:
    def execute(goal_handle: object) -> Fibonacci.Result:
        order = goal_handle.request.order  # type: ignore[attr-defined]
        sequence = [0, 1]
        for _ in range(order):
            sequence.append(sequence[-1] + sequence[-2])
            feedback = Fibonacci.Feedback()
            feedback.sequence = sequence
            goal_handle.publish_feedback(feedback)  # type: ignore[attr-defined]
        goal_handle.succeed()  # type: ignore[attr-defined]
        result = Fibonacci.Result()
        result.sequence = sequence
        return result

    ActionServer(node, Fibonacci, "fibonacci", execute)
    print("READY", flush=True)
    rclpy.spin(node)


def action_client(node: Node) -> None:
    client = ActionClient(node, Fibonacci, "fibonacci")
    print("READY", flush=True)
    client.wait_for_server()
    goal = Fibonacci.Goal()
    goal.order = 6
    goal_future = client.send_goal_async(goal)
    rclpy.spin_until_future_complete(node, goal_future)
    handle = goal_future.result()
    result_future = handle.get_result_async()
    rclpy.spin_until_future_complete(node, result_future)
    outcome = result_future.result()
    print(f"RESULT {outcome.status} {list(outcome.result.sequence)}", flush=True)


MODES = {
    "talker": talker,
    "listener": listener,
    "service_server": service_server,
    "service_client": service_client,
    "action_server": action_server,
    "action_client": action_client,
}


def main() -> None:
    rclpy.init()
    node = Node(f"plain_{sys.argv[1]}")
    try:
        MODES[sys.argv[1]](node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
