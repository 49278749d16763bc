"""A plain rclpy program using the interface package ``codecgen build --compile`` made.

Run by the compile tests in a separate process whose environment holds nothing but PATH, HOME,
PYTHONPATH (the install prefix's site-packages) and the test's DDS domain:
``python compiled_peer.py MODE`` with MODE one of check, talker, listener, service_server,
service_client, action_server, action_client. It prints ``READY`` when set up and one line per
result, and ends by itself (check, clients, listener) or on SIGTERM (servers, talker).
"""

from __future__ import annotations

import sys

import rclpy
from geometry_msgs.msg import Point
from rclpy.action import ActionClient, ActionServer
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from tutorial_interfaces.action import MoveTo
from tutorial_interfaces.msg import Num, Sphere
from tutorial_interfaces.srv import AddThreeInts


def check(node: Node) -> None:
    """Every kind of rclpy entity accepts the compiled types."""
    from rclpy.serialization import deserialize_message, serialize_message
    from tutorial_extras.msg import NumList

    node.create_publisher(Sphere, "sphere", 10)
    node.create_subscription(NumList, "num_list", lambda _msg: None, 10)
    node.create_service(AddThreeInts, "add_three_ints", lambda _req, res: res)
    node.create_client(AddThreeInts, "add_three_ints")
    ActionServer(node, MoveTo, "move_to", lambda handle: MoveTo.Result())
    ActionClient(node, MoveTo, "move_to")
    nums = NumList(label="x", nums=[Num(num=7)])
    back = deserialize_message(serialize_message(nums), NumList)
    print(f"READY {back.nums[0].num} {type(back.nums[0]).__module__}", flush=True)


def talker(node: Node) -> None:
    publisher = node.create_publisher(Num, "num", 10)
    count = iter(range(1_000_000))
    node.create_timer(0.02, lambda: publisher.publish(Num(num=next(count))))
    print("READY", flush=True)
    rclpy.spin(node)


def listener(node: Node) -> None:
    heard: list[Sphere] = []

    def on_sphere(msg: Sphere) -> None:
        heard.append(msg)
        print(f"HEARD {msg.header.frame_id} {msg.center.x} {msg.radius}", flush=True)

    node.create_subscription(Sphere, "sphere", on_sphere, 10)
    print("READY", flush=True)
    while rclpy.ok() and not heard:
        rclpy.spin_once(node, timeout_sec=0.1)


def service_server(node: Node) -> None:
    def add(request: AddThreeInts.Request, response: AddThreeInts.Response) -> object:
        response.sum = request.a + request.b + request.c
        return response

    node.create_service(AddThreeInts, "add_three_ints", add)
    print("READY", flush=True)
    rclpy.spin(node)


def service_client(node: Node) -> None:
    client = node.create_client(AddThreeInts, "add_three_ints")
    print("READY", flush=True)
    client.wait_for_service()
    future = client.call_async(AddThreeInts.Request(a=1, b=2, c=3))
    rclpy.spin_until_future_complete(node, future)
    print(f"RESPONSE {future.result().sum}", flush=True)  # type: ignore[union-attr]


def action_server(node: Node) -> None:
    def execute(goal_handle: object) -> MoveTo.Result:
        target = goal_handle.request.target  # type: ignore[attr-defined]
        for remaining in (2.0, 1.0):
            goal_handle.publish_feedback(MoveTo.Feedback(remaining=remaining))  # type: ignore[attr-defined]
        goal_handle.succeed()  # type: ignore[attr-defined]
        return MoveTo.Result(reached=True, message=f"at {target.x} {target.y} {target.z}")

    ActionServer(node, MoveTo, "move_to", execute)
    print("READY", flush=True)
    rclpy.spin(node)


def action_client(node: Node) -> None:
    client = ActionClient(node, MoveTo, "move_to")
    print("READY", flush=True)
    client.wait_for_server()
    goal = MoveTo.Goal(target=Point(x=1.0, y=2.0, z=3.0), speed=0.5)
    sent = client.send_goal_async(
        goal, feedback_callback=lambda fb: print(f"FEEDBACK {fb.feedback.remaining}", flush=True)
    )
    rclpy.spin_until_future_complete(node, sent)
    result = sent.result().get_result_async()  # type: ignore[union-attr]
    rclpy.spin_until_future_complete(node, result)
    outcome = result.result()
    print(f"RESULT {outcome.status} {outcome.result.reached} {outcome.result.message}", flush=True)  # type: ignore[union-attr]


MODES = {
    f.__name__: f
    for f in (check, talker, listener, service_server, service_client, action_server, action_client)
}

if __name__ == "__main__":
    rclpy.init()
    peer = Node(f"compiled_peer_{sys.argv[1]}")
    try:
        MODES[sys.argv[1]](peer)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        peer.destroy_node()
        rclpy.try_shutdown()
