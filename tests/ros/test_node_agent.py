"""The agent base (pyconnect.ros.node_agent): the ``codec=`` option is checked when it is made."""

from __future__ import annotations

from typing import Any

import pytest
from std_msgs.msg import String

from pyconnect.errors import PyconnectError


class UpperCodec:
    msg_type = "std_msgs/msg/String"
    lossless = True

    def encode(self, value: Any) -> Any:
        return String(data=value.upper())

    def decode(self, msg: Any) -> Any:
        return msg.data.lower()


def test_a_codec_class_instead_of_an_instance_is_refused(make_node: Any) -> None:
    # It was accepted; send() then failed with "encode() missing 1 required positional argument".
    node = make_node("codec_class")
    with pytest.raises(PyconnectError) as raised:
        node.add_agent(conn_name="status", conn_type="pub", data_interface=String, codec=UpperCodec)
    assert str(raised.value) == (
        "agent 'status' (pub std_msgs/msg/String): codec: expected a codec instance, got the "
        "class UpperCodec; did you mean UpperCodec()?"
    )
    assert "status" not in node.agents
    agent = node.add_agent(
        conn_name="status", conn_type="pub", data_interface=String, codec=UpperCodec()
    )
    assert agent.send("hi") is True
