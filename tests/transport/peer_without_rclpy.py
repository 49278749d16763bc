"""A peer in a process where ``import rclpy`` fails (run by the transport and bridge tests).

``python peer_without_rclpy.py CONFIG ROLE TOPIC``: ROLE ``echo-image`` receives Images on TOPIC
and republishes each on TOPIC + '_back'; ``fibonacci-server`` serves the action
``test_msgs/action/Fibonacci`` on TOPIC (with feedback); ``spin`` just spins (signal tests);
``spin-twice`` spins, then makes a second peer and spins again; ``stop-service`` serves a
``std_srvs/srv/Trigger`` on TOPIC whose handler shuts the peer down; ``no-shutdown`` ends the
script without shutting its peer down; ``raising-sub`` sends itself one String on TOPIC that its
handler refuses. It prints ``ready`` once its agents exist.
"""

from __future__ import annotations

import importlib.abc
import sys
from typing import Any


class _BlockRos(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname: str, path: object, target: object = None) -> None:
        if fullname == "rclpy" or fullname.startswith(("rclpy.", "rpyutils")):
            raise ImportError(f"{fullname} is blocked in this process")


sys.meta_path.insert(0, _BlockRos())


def main() -> None:
    from pyconnect.transport import Peer

    config, role, topic = sys.argv[1:4]
    try:
        import rclpy  # noqa: F401
    except ImportError:
        pass
    else:
        raise SystemExit("rclpy imported although blocked")
    # Printed at shutdown however it comes (a signal may arrive before spin() is reached).
    peer = Peer(
        "vision", config=config, stop_func=lambda: print("rclpy" in sys.modules, flush=True)
    )
    if role == "echo-image":
        back = peer.add_agent(
            conn_name=f"{topic}_back", conn_type="pub", data_interface="sensor_msgs/msg/Image"
        )
        peer.add_agent(
            conn_name=topic,
            conn_type="sub",
            data_interface="sensor_msgs/msg/Image",
            response_func=back.send,
        )
    if role == "fibonacci-server":

        def fibonacci(goal: dict[str, int], publish_feedback: Any) -> dict[str, list[int]]:
            sequence = [0, 1]
            for _ in range(goal["order"]):
                sequence.append(sequence[-1] + sequence[-2])
                publish_feedback({"sequence": sequence})
            return {"sequence": sequence}

        peer.add_agent(
            conn_name=topic,
            conn_type="action_server",
            data_interface="test_msgs/action/Fibonacci",
            response_func=fibonacci,
        )
    if role == "stop-service":

        def stop(_request: Any) -> dict[str, Any]:
            peer.shutdown()  # from the handler's own thread: the reply still goes out
            return {"success": True, "message": "stopping"}

        peer.add_agent(
            conn_name=topic,
            conn_type="service_server",
            data_interface="std_srvs/srv/Trigger",
            response_func=stop,
        )
    if role == "raising-sub":  # a handler that raises, in a program that configures no logging

        def fail(_value: Any) -> None:
            raise RuntimeError("no use for it")

        sub = peer.add_agent(
            conn_name=topic, conn_type="sub", data_interface="std_msgs/msg/String", response_func=fail
        )
        out = peer.add_agent(
            conn_name=topic, agent_name="out", conn_type="pub", data_interface="std_msgs/msg/String"
        )
        print("ready", flush=True)
        peer.wait_for_graph(lambda: out.subscriber_count > 0, None)
        out.send("hello")
        sub.wait_for_message(60)
        peer.shutdown()
        return
    if role == "no-shutdown":
        peer.add_agent(conn_name=topic, conn_type="sub", data_interface="std_msgs/msg/String")
        print("ready", flush=True)
        return  # the interpreter's exit shuts the peer down
    if role != "spin-twice":
        print("ready", flush=True)
        peer.spin()
        return
    try:
        print("ready", flush=True)
        peer.spin()
    except SystemExit:  # the signal came before spin() was reached
        peer.wait_for_shutdown()
    with Peer("vision_again", config=config, stop_func=lambda: print("again", flush=True)) as again:
        print("ready", flush=True)
        again.spin()


if __name__ == "__main__":
    main()
