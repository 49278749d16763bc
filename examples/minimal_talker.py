"""The design's "Full Minimal Example", talker side: a periodic pub that sends every second.

No ``send()`` and no ``response_func``: until a value is sent, a periodic pub hands its
``encode_func`` ``None`` and publishes the message the function fills in. Run
``python -m examples.minimal_talker`` and ``python -m examples.minimal_listener``.
"""

import time

from std_msgs.msg import String

from pyconnect.ros.custom_node import CustomNode
from pyconnect.utils import dict2str


def encode_func(data, msg):
    # data is None until something was send()-ed: make the message from the robot's state.
    msg.data = dict2str(data if data is not None else {"status": "alive", "time": time.time()})
    return msg


node = CustomNode("talker")
node.add_agent(
    conn_name="chatter",
    conn_type="pub",
    data_interface=String,
    encode_func=encode_func,
    time_period=1.0,
)
node.spin()
