"""A CustomNode that bridges /camera to zenoh and /camera_back from zenoh (run by test_bridge).

The zenoh side reads its session config from ZENOH_SESSION_CONFIG_URI, as rmw_zenoh does.
"""

from __future__ import annotations

from sensor_msgs.msg import Image

from pyconnect.ros.custom_node import CustomNode


def main() -> None:
    node = CustomNode("bridge")
    node.add_agent(conn_name="camera", conn_type="sub", data_interface=Image, transport="zenoh")
    node.add_agent(
        conn_name="camera_back", conn_type="pub", data_interface=Image, transport="zenoh"
    )
    print("ready", flush=True)
    node.spin()


if __name__ == "__main__":
    main()
