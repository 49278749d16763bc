"""The seed's minimal talker: a ``String`` topic carrying ``dict2str(data)``, twice a second.

Run ``python -m examples.talker`` and, in another terminal, ``python -m examples.listener``.
"""

from __future__ import annotations

import itertools

from std_msgs.msg import String

from pyconnect.ros.custom_node import CustomNode
from pyconnect.utils import dict2str


def encode_command(data: dict[str, object], msg: String) -> String:
    msg.data = dict2str(data)
    return msg


def main() -> None:
    node = CustomNode(name="talker")
    counter = itertools.count()
    node.add_agent(
        conn_name="command",
        conn_type="pub",
        data_interface=String,
        encode_func=encode_command,
        time_period=0.5,
        response_func=lambda: {"cmd": "forward", "speed": 0.5, "count": next(counter)},
    )
    node.spin()


if __name__ == "__main__":
    main()
