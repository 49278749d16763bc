"""The agent factory (pyconnect.ros.agent_factory): option values of the wrong type are refused
when the agent is made, naming the agent and the option."""

from __future__ import annotations

import sys
from typing import Any

import pytest
from rclpy.callback_groups import ReentrantCallbackGroup
from sensor_msgs.msg import Image
from std_msgs.msg import String
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci

from pyconnect.errors import PyconnectError
from pyconnect.ros.agent_options import OptionError


@pytest.mark.parametrize(
    ("options", "expected"),
    [
        (
            {"conn_type": "sub", "data_interface": String, "response_func": "on_message"},
            "agent 'bad' (sub): response_func: expected a callable, got 'on_message'; pass the "
            "function itself, not its name",
        ),
        (
            {"conn_type": "service_server", "data_interface": SetBool, "response_func": 42},
            "agent 'bad' (service_server): response_func: expected a callable, got 42",
        ),
        (
            {"conn_type": "pub", "data_interface": String, "encode_func": "x"},
            "agent 'bad' (pub): encode_func: expected a callable, got 'x'; pass the function "
            "itself, not its name",
        ),
        (
            {"conn_type": "sub", "data_interface": String, "decode_func": 1},
            "agent 'bad' (sub): decode_func: expected a callable, got 1",
        ),
        (
            {"conn_type": "sub", "data_interface": String, "callback_group": "fast"},
            "agent 'bad' (sub): callback_group: expected an rclpy CallbackGroup (e.g. "
            "ReentrantCallbackGroup()), got 'fast'",
        ),
        (
            {"conn_type": "sub", "data_interface": String,
             "callback_group": ReentrantCallbackGroup},
            "agent 'bad' (sub): callback_group: expected an rclpy CallbackGroup (e.g. "
            "ReentrantCallbackGroup()), got the class ReentrantCallbackGroup; did you mean "
            "ReentrantCallbackGroup()?",
        ),
        (
            {"conn_type": "timer", "time_period": 1.0, "response_func": lambda tick: None},
            "agent 'bad' (timer): response_func: a timer calls it with no arguments, but it "
            "requires 'tick'",
        ),
        (
            {"conn_type": ["pub"], "data_interface": String},
            "agent 'bad': conn_type: expected one of 'sub', 'pub', 'service_client', "
            "'service_server', 'action_client', 'action_server', 'timer', got ['pub']",
        ),
    ],
)  # fmt: skip
def test_option_values_of_the_wrong_type_are_refused(
    make_node: Any, options: dict[str, Any], expected: str
) -> None:
    # Each was accepted and failed per message ("'str' object is not callable"), inside rclpy
    # ("'str' object has no attribute 'add_entity'") or as "unhashable type: 'list'".
    node = make_node("option_values")
    with pytest.raises(OptionError) as raised:
        node.add_agent(conn_name="bad", **options)
    assert str(raised.value) == expected
    assert "bad" not in node.agents


def test_callables_and_timer_handlers_without_required_parameters_are_accepted(
    make_node: Any,
) -> None:
    class Handler:
        def __call__(self, *args: Any) -> None:
            return None

    node = make_node("option_values_ok")
    node.add_agent(conn_name="t1", conn_type="timer", time_period=1.0, response_func=lambda: 1)
    node.add_agent(
        conn_name="t2", conn_type="timer", time_period=1.0,
        response_func=lambda tick=0, *rest, **named: tick,
    )  # fmt: skip
    node.add_agent(conn_name="t3", conn_type="timer", time_period=1.0, response_func=Handler())
    node.add_agent(conn_name="t4", conn_type="timer", time_period=1.0, response_func=print)
    node.add_agent(
        conn_name="s", conn_type="sub", data_interface=String, response_func=Handler(),
        decode_func=str, callback_group=ReentrantCallbackGroup(),
    )  # fmt: skip
    assert sorted(node.agents) == ["s", "t1", "t2", "t3", "t4"]


@pytest.mark.parametrize(
    ("conn_type", "data_interface"),
    [
        ("sub", String),
        ("sub", Image),  # a sensor sub asks the graph first
        ("pub", String),
        ("service_server", SetBool),
        ("service_client", SetBool),
        ("action_server", Fibonacci),
        ("action_client", Fibonacci),
    ],
)
@pytest.mark.parametrize("conn_name", ["front camera", "1abc", "cam/"])
def test_a_name_rclpy_refuses_is_an_option_error_naming_the_agent(
    make_node: Any, conn_type: str, data_interface: type, conn_name: str
) -> None:
    """rclpy's InvalidTopicNameException, RCLError or ValueError named no agent (and an
    action client was left half made)."""
    node = make_node("names")
    handlers = {
        "service_server": {"response_func": lambda request: {}},
        "action_server": {"response_func": lambda goal: {}},
    }
    with pytest.raises(OptionError) as refused:
        node.add_agent(
            conn_name=conn_name,
            conn_type=conn_type,
            data_interface=data_interface,
            **handlers.get(conn_type, {}),
        )
    text = str(refused.value)
    assert text.startswith(f"agent {conn_name!r} ({conn_type}): ")
    assert "invalid" in text.lower()
    assert node.agents == {}


def test_a_misspelt_transport_is_refused_before_zenoh_is_imported(
    make_node: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Without the zenoh extra, transport='zneoh' said "No module named 'zenoh'"."""
    monkeypatch.setitem(sys.modules, "zenoh", None)
    monkeypatch.delitem(sys.modules, "pyconnect.ros.zenoh_bridge", raising=False)
    node = make_node("bridge_less")
    with pytest.raises(PyconnectError, match="unknown transport 'zneoh'; expected 'zenoh'"):
        node.add_agent(conn_name="a", conn_type="sub", data_interface=String, transport="zneoh")
    with pytest.raises(
        OptionError, match=r"needs eclipse-zenoh: pip install 'pyconnect-ros\[zenoh\]'"
    ):
        node.add_agent(conn_name="a", conn_type="sub", data_interface=String, transport="zenoh")
