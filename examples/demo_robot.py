"""The demo's simulated robot: camera, joint states, laser scan, a motor service, a navigate action.

Written with pyconnect agents too: each sensor is a ``pub`` agent whose ``response_func``
makes the next reading. Prints ``READY`` once set up; ends on SIGINT/SIGTERM.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
from geometry_msgs.msg import Twist
from sensor_msgs.msg import Image, JointState, LaserScan
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci

from pyconnect.codecs.laser_scan import LaserScanValue
from pyconnect.ros.custom_node import CustomNode


class SimulatedRobot:
    """A differential-drive robot with a camera, two wheels and a 360-beam lidar."""

    def __init__(self) -> None:
        self.start = time.monotonic()
        self.motors_enabled = False
        self.velocity = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        self.wheel_angle = [0.0, 0.0]

    def camera_frame(self) -> np.ndarray:
        """A 120x160 rgb8 frame: a gradient that drifts with time."""
        shift = int((time.monotonic() - self.start) * 40) % 160
        row = np.roll(np.arange(160, dtype=np.uint8), shift)
        frame = np.zeros((120, 160, 3), dtype=np.uint8)
        frame[:, :, 1] = row
        frame[:, :, 2] = 255 - row
        return frame

    def joint_states(self) -> dict[str, dict[str, float]]:
        speed = self.velocity[0][0] if self.motors_enabled else 0.0
        self.wheel_angle = [angle + speed * 0.05 for angle in self.wheel_angle]
        return {
            "left_wheel": {"position": self.wheel_angle[0], "velocity": speed},
            "right_wheel": {"position": self.wheel_angle[1], "velocity": speed},
        }

    def scan(self) -> LaserScanValue:
        elapsed = time.monotonic() - self.start
        angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
        # Something in front comes and goes: the nearest range swings between 1.1 and 1.9 m.
        ranges = (2.0 + 0.5 * np.sin(angles * 3 + elapsed) + 0.4 * np.sin(elapsed / 2)).astype(
            np.float32
        )
        return LaserScanValue(
            ranges=ranges,
            angle_min=-math.pi,
            angle_max=math.pi,
            angle_increment=2 * math.pi / 360,
            range_min=0.1,
            range_max=10.0,
        )

    def set_motors(self, request: dict[str, Any]) -> dict[str, Any]:
        self.motors_enabled = bool(request["data"])
        state = "enabled" if self.motors_enabled else "disabled"
        print(f"[robot] motors {state}", flush=True)
        return {"success": True, "message": f"motors {state}"}

    def navigate(self, goal: dict[str, Any]) -> Iterator[dict[str, Any]]:
        """Drive through ``order`` waypoints; feedback lists the waypoints reached."""
        reached: list[int] = []
        for waypoint in range(goal["order"]):
            time.sleep(0.2)  # driving to the next waypoint
            reached.append(waypoint)
            yield {"sequence": list(reached)}
        print(f"[robot] reached {len(reached)} waypoints", flush=True)
        return {"sequence": reached}

    def on_cmd_vel(self, velocity: tuple[Any, Any]) -> None:
        self.velocity = velocity


def main() -> None:
    robot = SimulatedRobot()
    with CustomNode("demo_robot") as node:
        node.add_agents(
            [
                {
                    "conn_name": "camera/image",
                    "data_interface": Image,
                    "time_period": 0.1,
                    "response_func": robot.camera_frame,
                    "frame_id": "camera",
                },
                {
                    "conn_name": "joint_states",
                    "data_interface": JointState,
                    "time_period": 0.05,
                    "response_func": robot.joint_states,
                },
                {
                    "conn_name": "scan",
                    "data_interface": LaserScan,
                    "time_period": 0.1,
                    "response_func": robot.scan,
                    "frame_id": "lidar",
                },
            ],
            conn_type="pub",
        )
        node.add_agent(
            conn_name="cmd_vel",
            conn_type="sub",
            data_interface=Twist,
            response_func=robot.on_cmd_vel,
        )
        node.add_agent(
            conn_name="enable_motors",
            conn_type="service_server",
            data_interface=SetBool,
            response_func=robot.set_motors,
        )
        node.add_agent(
            conn_name="navigate",
            conn_type="action_server",
            data_interface=Fibonacci,
            response_func=robot.navigate,
        )
        node.spin(run_thread=True)
        print("READY", flush=True)
        node.wait_for_shutdown()
    print("[robot] stopped", flush=True)


if __name__ == "__main__":
    main()
