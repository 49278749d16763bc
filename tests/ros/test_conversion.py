"""An agent's conversion (pyconnect.ros.conversion): a codec whose encode builds another type."""

from __future__ import annotations

from typing import Any

import pytest
from std_msgs.msg import Int32, String
from std_srvs.srv import SetBool, Trigger

from pyconnect import codecs
from pyconnect.errors import EncodeError
from pyconnect.ros.conversion import MessageConversion

from .conftest import EVENT_TIMEOUT


class LengthCodec:
    """A newcomer's String codec that builds an Int32 by mistake."""

    msg_type = "std_msgs/msg/String"
    lossless = False

    def encode(self, value: Any) -> Any:
        return Int32(data=len(value))

    def decode(self, msg: Any) -> Any:
        return msg.data


class ReplyCodec:
    """A SetBool response codec that builds a Trigger response by mistake."""

    msg_type = "std_srvs/srv/SetBool_Response"
    lossless = False

    def encode(self, value: Any) -> Any:
        return Trigger.Response(success=True, message=value)

    def decode(self, msg: Any) -> Any:
        return msg.message


def test_a_codec_that_builds_another_type_is_an_encode_error_naming_agent_and_codec() -> None:
    # rclpy raised "Expected <String>, got <Int32>" at publish, naming neither.
    codec = LengthCodec()
    conversion = MessageConversion(
        describe="agent 'status' (pub std_msgs/msg/String)", msg_class=String,
        codec_of=lambda: codec,
    )  # fmt: skip
    with pytest.raises(EncodeError) as raised:
        conversion.encode("ok")
    assert str(raised.value) == (
        "agent 'status' (pub std_msgs/msg/String): codec LengthCodec.encode returned Int32, "
        "expected std_msgs/msg/String"
    )
    right = MessageConversion(describe="agent 'status'", msg_class=String,
                              codec_of=lambda: codecs.default_registry.lookup_message(String))  # fmt: skip
    msg, stamped = right.encode("ok")
    assert type(msg) is String and msg.data == "ok" and not stamped


def test_a_service_server_whose_codec_builds_another_type_answers_with_the_error(
    make_node: Any,
) -> None:
    # The server logged a bare "callback raised TypeError: " and the client waited its timeout.
    registry = codecs.Registry()
    registry.register(SetBool.Response, ReplyCodec())
    server_node = make_node("wrong_reply_server", registry=registry)
    server_node.add_agent(
        conn_name="enable", conn_type="service_server", data_interface=SetBool,
        response_func=lambda request: "enabled",
    )  # fmt: skip
    client_node = make_node("wrong_reply_client")
    client = client_node.add_agent(
        conn_name="enable", conn_type="service_client", data_interface=SetBool,
        timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    server_node.spin(run_thread=True)
    client_node.spin(run_thread=True)
    client_node.wait_until_connected(timeout=EVENT_TIMEOUT)
    answer = client.send({"data": True})
    assert answer == {
        "success": False,
        "message": "EncodeError: agent 'enable' (service_server std_srvs/srv/SetBool): codec "
        "ReplyCodec.encode returned Trigger_Response, expected std_srvs/srv/SetBool_Response",
        "isdone": True,
    }
    assert server_node.agents["enable"].error_count == 1
