"""A plain rclpy process for the live-tool tests: topics, a service, an action, a subscriber.

Besides /chatter and /image it publishes /scan (LaserScan), /joint_states and /bad_image, whose
every other frame is too short to decode (the echo must go on past it). Run as ``python -m tests.commands.plain_peer``; prints ``ready`` once everything is created,
``got <data>`` for each String received on /commands, and exits on SIGINT or stdin closing.
"""

from __future__ import annotations

import sys
import threading
import time

import rclpy
from rclpy.action import ActionServer
from rclpy.executors import Executor, ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import Image, JointState, LaserScan
from std_msgs.msg import String
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci


def main() -> None:
    rclpy.init()
    node = Node("plain_peer")
    chatter = node.create_publisher(String, "chatter", 10)
    image = node.create_publisher(Image, "image", 10)
    scan = node.create_publisher(LaserScan, "scan", 10)
    joints = node.create_publisher(JointState, "joint_states", 10)
    bad_image = node.create_publisher(Image, "bad_image", 10)
    count = [0]

    def tick() -> None:
        count[0] += 1
        chatter.publish(String(data=f"hello {count[0]}"))
        image.publish(
            Image(height=2, width=2, encoding="mono8", step=2, data=bytes([0, 10, 20, 30]))
        )
        scan.publish(
            LaserScan(
                angle_min=-1.0,
                angle_max=1.0,
                angle_increment=1.0,
                range_max=10.0,
                ranges=[1.0, 2.0, 3.0],
            )
        )
        joints.publish(JointState(name=["a", "b"], position=[1.0, 2.5]))
        short = count[0] % 2 == 1  # 2 bytes where a 2x2 mono8 frame needs 4
        bad_image.publish(
            Image(height=2, width=2, encoding="mono8", step=2, data=bytes(2 if short else 4))
        )

    node.create_timer(0.05, tick)

    def on_command(msg: String) -> None:
        print(f"got {msg.data}", flush=True)

    node.create_subscription(String, "commands", on_command, 10)

    def set_flag(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        response.success = request.data
        response.message = f"flag is {request.data}"
        return response

    node.create_service(SetBool, "set_flag", set_flag)

    def fibonacci(goal_handle: object) -> Fibonacci.Result:
        order = goal_handle.request.order  # type: ignore[attr-defined]
        # The client's feedback reader may not be matched yet when its goal arrives (rclpy's
        # wait_for_server looks at the services only): wait for it, or the first feedback is
        # lost and the test counts 2 of 3 (1 run in ~10 on a loaded machine).
        deadline = time.monotonic() + 20
        while (
            not node.count_subscribers("/fibonacci/_action/feedback")
            and time.monotonic() < deadline
        ):
            time.sleep(0.01)
        sequence = [0, 1]
        for _ in range(order - 1):
            sequence.append(sequence[-1] + sequence[-2])
            feedback = Fibonacci.Feedback(sequence=sequence)
            goal_handle.publish_feedback(feedback)  # type: ignore[attr-defined]
            time.sleep(0.01)
        goal_handle.succeed()  # type: ignore[attr-defined]
        return Fibonacci.Result(sequence=sequence)

    ActionServer(node, Fibonacci, "fibonacci", fibonacci)
    executor = MultiThreadedExecutor()
    executor.add_node(node)
    serve(executor)


def serve(executor: Executor) -> None:
    """Say "ready", then spin until the test closes stdin (or Ctrl-C)."""

    def watch_stdin() -> None:
        sys.stdin.read()
        rclpy.try_shutdown()

    threading.Thread(target=watch_stdin, daemon=True).start()
    print("ready", flush=True)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
