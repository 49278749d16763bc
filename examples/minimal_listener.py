"""The design's "Full Minimal Example", listener side: prints what the talker sends."""

from std_msgs.msg import String

from pyconnect.ros.custom_node import CustomNode
from pyconnect.utils import str2dict


def decode_func(msg):
    return str2dict(msg.data)


def response_func(data):
    print(f"received {data}", flush=True)


node = CustomNode("listener")
node.add_agent(
    conn_name="chatter",
    conn_type="sub",
    data_interface=String,
    decode_func=decode_func,
    response_func=response_func,
)
node.spin()
