"""The seed's minimal listener: prints the dicts the talker sends over a ``String`` topic."""

from __future__ import annotations

from std_msgs.msg import String

from pyconnect.ros.custom_node import CustomNode
from pyconnect.utils import str2dict


def decode_command(msg: String) -> object:
    return str2dict(msg.data)


def main() -> None:
    node = CustomNode(name="listener")
    node.add_agent(
        conn_name="command",
        conn_type="sub",
        data_interface=String,
        decode_func=decode_command,
        response_func=lambda data: print(f"heard {data}", flush=True),
    )
    node.spin()


if __name__ == "__main__":
    main()
