"""The demo's "brain": zero-boilerplate agents — no encode/decode functions anywhere.

Images arrive as numpy arrays, joint states as a dict, the scan as ``LaserScanValue``, the
velocity command goes out as a tuple pair; services and actions take and return dicts.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from geometry_msgs.msg import Twist
from sensor_msgs.msg import Image, JointState, LaserScan
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci

from pyconnect.ros.custom_node import CustomNode


class Brain:
    """Looks at the camera and the lidar, drives forward while the way is clear."""

    def __init__(self) -> None:
        self.frames = 0
        self.brightness = 0.0
        self.nearest = float("inf")

    def on_image(self, frame: np.ndarray) -> None:
        self.frames += 1
        self.brightness = float(frame.mean())

    def on_scan(self, scan: Any) -> None:
        self.nearest = float(np.nanmin(scan.ranges))

    def command(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        speed = 0.3 if self.nearest > 1.6 else 0.0
        return ((speed, 0.0, 0.0), (0.0, 0.0, 0.2))


def run(duration: float, *, log_dir: str | None = None) -> None:
    brain = Brain()
    with CustomNode(
        "demo_brain", log_dir=log_dir, stop_func=lambda: print("[brain] stop_func: stopping")
    ) as node:
        node.add_agent(
            conn_name="camera/image",
            conn_type="sub",
            data_interface=Image,
            response_func=brain.on_image,
        )
        node.add_agent(
            conn_name="joint_states", conn_type="sub", data_interface=JointState, do_log_msg=True
        )
        node.add_agent(
            conn_name="scan", conn_type="sub", data_interface=LaserScan, response_func=brain.on_scan
        )
        node.add_agent(
            conn_name="cmd_vel",
            conn_type="pub",
            data_interface=Twist,
            time_period=0.1,
            response_func=brain.command,
        )
        node.add_agent(
            conn_name="enable_motors",
            conn_type="service_client",
            data_interface=SetBool,
            timeout=10.0,
        )
        node.add_agent(
            conn_name="navigate", conn_type="action_client", data_interface=Fibonacci, timeout=30.0
        )
        node.spin(run_thread=True)
        node.wait_until_connected(timeout=30.0)
        print("[brain] connected to every robot agent", flush=True)
        node.start_log_subs(fps=5)

        reply = node.agents["enable_motors"].send({"data": True})
        print(f"[brain] enable_motors -> {reply}", flush=True)
        result = node.agents["navigate"].send(
            {"order": 5},
            feedback_func=lambda feedback: print(
                f"[brain] navigate feedback {feedback}", flush=True
            ),
        )
        print(f"[brain] navigate -> {result}", flush=True)

        deadline = time.monotonic() + duration
        while time.monotonic() < deadline and node.ok():
            joints = node.agents["joint_states"].get()
            left = joints["left_wheel"]["position"] if joints else float("nan")
            print(
                f"[brain] frames={brain.frames} brightness={brain.brightness:.1f} "
                f"nearest={brain.nearest:.2f} m left_wheel={left:.2f} rad "
                f"cmd_vel={node.agents['cmd_vel'].get()}",
                flush=True,
            )
            node.wait_for_shutdown(timeout=1.0)
        if node.ok():  # not after Ctrl-C, which already shut the node down
            node.agents["enable_motors"].send({"data": False})
            node.stop_log_subs()
        print(f"[brain] logs in {node.log_dir / node.name}", flush=True)


if __name__ == "__main__":
    run(15.0)
