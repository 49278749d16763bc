"""A CustomNode bridging one String topic from zenoh to ROS (run by test_bridge's loop test).

It prints ``value V`` for every sample its bridge's zenoh session receives (a second
subscriber on the bridge's own peer), so the test knows what has reached the bridge.
"""

from __future__ import annotations

import sys

from std_msgs.msg import String

from pyconnect.ros.custom_node import CustomNode


def main() -> None:
    node = CustomNode("far_bridge")
    bridge = node.add_agent(
        conn_name=sys.argv[1], conn_type="pub", data_interface=String, transport="zenoh"
    )
    bridge.peer.add_agent(  # type: ignore[attr-defined]
        conn_name=bridge.topic,
        agent_name="watch",
        conn_type="sub",
        data_interface="std_msgs/msg/String",
        response_func=lambda value: print(f"value {value}", flush=True),
    )
    print("ready", flush=True)
    node.spin()


if __name__ == "__main__":
    main()
