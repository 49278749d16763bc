"""The agent factory (pyconnect.ros.agent_factory): option values of the wrong type are refused
when the agent is made, naming the agent and the option."""

from __future__ import annotations

import functools
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
            {"conn_type": "pub", "data_interface": String, "time_period": 1.0,
             "response_func": lambda who: f"hi {who}"},
            "agent 'bad' (pub): response_func: a periodic pub calls it with no arguments, but "
            "it requires 'who'",
        ),
        (
            {"conn_type": "sub", "data_interface": String, "response_func": lambda: None},
            "agent 'bad' (sub): response_func: a sub calls it with one argument (the value), "
            "but it takes no positional arguments",
        ),
        (
            {"conn_type": "service_server", "data_interface": SetBool,
             "response_func": lambda: {"success": True}},
            "agent 'bad' (service_server): response_func: a service_server calls it with one "
            "argument (the request), but it takes no positional arguments",
        ),
        (
            {"conn_type": "action_server", "data_interface": Fibonacci,
             "response_func": lambda: {}},
            "agent 'bad' (action_server): response_func: an action_server calls it with one "
            "argument (the goal), but it takes no positional arguments",
        ),
        (
            {"conn_type": "action_server", "data_interface": Fibonacci,
             "response_func": lambda goal, publish_feedback, scale: {}},
            "agent 'bad' (action_server): response_func: an action_server calls it with two "
            "arguments (the goal and publish_feedback, as it takes a second positional "
            "parameter), but it requires 'goal', 'publish_feedback', 'scale'",
        ),
        (
            {"conn_type": "action_client", "data_interface": Fibonacci,
             "accepted_func": lambda: None},
            "agent 'bad' (action_client): accepted_func: an action_client calls it with one "
            "argument (accepted: bool), but it takes no positional arguments",
        ),
        (
            {"conn_type": "timer", "time_period": 1.0, "response_func": None},
            "agent 'bad' (timer): missing option 'response_func'",
        ),
        (
            {"conn_type": "action_server", "data_interface": Fibonacci,
             "response_func": lambda goal: {}, "result_timeout": -1},
            "agent 'bad' (action_server): result_timeout must be a finite number of seconds "
            ">= 0, got -1",
        ),
        (
            {"conn_type": "action_server", "data_interface": Fibonacci,
             "response_func": lambda goal: {}, "result_timeout": "0.5"},
            "agent 'bad' (action_server): result_timeout must be a finite number of seconds "
            ">= 0, got '0.5'",
        ),
        (
            {"conn_type": "action_server", "data_interface": Fibonacci,
             "response_func": lambda goal: {}, "result_cache_seconds": float("nan")},
            "agent 'bad' (action_server): result_cache_seconds must be a finite number of "
            "seconds >= 0, got nan",
        ),
        (
            {"conn_type": "action_server", "data_interface": Fibonacci,
             "response_func": lambda goal: {}, "result_cache_seconds": -5},
            "agent 'bad' (action_server): result_cache_seconds must be a finite number of "
            "seconds >= 0, got -5",
        ),
        (
            {"conn_type": "pub", "data_interface": String, "do_log_msg": "no"},
            "agent 'bad' (pub): do_log_msg: expected bool or None, got 'no'",
        ),
        (
            {"conn_type": "pub", "data_interface": String, "only_if_subscribed": "no"},
            "agent 'bad' (pub): only_if_subscribed: expected bool or None, got 'no'",
        ),
        (
            {"conn_type": "pub", "data_interface": String, "raw": 0},
            "agent 'bad' (pub): raw: expected bool or None, got 0",
        ),
        (
            {"conn_type": "sub", "data_interface": String, "stamped": "yes"},
            "agent 'bad' (sub): stamped: expected bool or None, got 'yes'",
        ),
        (
            {"conn_type": "pub", "data_interface": Image, "frame_id": 5},
            "agent 'bad' (pub): frame_id: expected str or None, got 5",
        ),
        (
            {"conn_type": "pub", "data_interface": String, "agent_name": 5},
            "agent 'bad': agent_name: expected str or None, got 5",
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
    # ("'str' object has no attribute 'add_entity'", a pybind TypeError), as "unhashable type:
    # 'list'", at every call or tick (a handler that cannot take its arguments), or changed
    # what the agent does (do_log_msg="no" logged, raw=0 took the raw path).
    node = make_node("option_values")
    with pytest.raises(OptionError) as raised:
        node.add_agent(conn_name="bad", **options)
    assert str(raised.value) == expected
    assert node.agents == {}


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


def _logged(function: Any) -> Any:
    @functools.wraps(function)
    def wrapper(*args: Any, **named: Any) -> Any:
        return function(*args, **named)

    return wrapper


class Anything:
    def __call__(self, *args: Any) -> None:
        return None


class Receiver:
    def on_value(self, value: Any) -> None:
        return None

    def run(self, goal: Any, publish_feedback: Any) -> Any:
        return {}


async def on_request(request: Any) -> Any:
    return {"success": True}


def fibonacci(goal: Any) -> Any:
    yield {"sequence": [0]}
    return {"sequence": [0, 1]}


def with_default(value: Any, scale: float = 1.0) -> None:
    return None


@pytest.mark.parametrize(
    ("conn_type", "options"),
    [
        ("pub", {"data_interface": String, "time_period": 1.0, "response_func": lambda: "x"}),
        ("pub", {"data_interface": String, "time_period": 1.0, "response_func": Anything()}),
        ("sub", {"data_interface": String, "response_func": Receiver().on_value}),
        ("sub", {"data_interface": String, "response_func": functools.partial(with_default)}),
        ("sub", {"data_interface": String, "response_func": _logged(with_default)}),
        ("sub", {"data_interface": String, "response_func": print}),
        ("sub", {"data_interface": String, "response_func": lambda *values: None}),
        ("service_server", {"data_interface": SetBool, "response_func": on_request}),
        ("service_server", {"data_interface": SetBool, "response_func": Anything()}),
        ("action_server", {"data_interface": Fibonacci, "response_func": fibonacci}),
        ("action_server", {"data_interface": Fibonacci, "response_func": Receiver().run}),
        ("action_server", {"data_interface": Fibonacci,
                           "response_func": lambda goal, publish_feedback=None: {}}),
        ("action_client", {"data_interface": Fibonacci, "accepted_func": print,
                           "feedback_func": Receiver().on_value,
                           "response_func": on_request}),
        ("pub", {"data_interface": Image, "frame_id": "camera", "do_log_msg": True,
                 "only_if_subscribed": False, "raw": None, "agent_name": "out"}),
        ("sub", {"data_interface": String, "raw": False, "stamped": False}),
        ("action_server", {"data_interface": Fibonacci, "response_func": fibonacci,
                           "result_timeout": 0, "result_cache_seconds": 0.5}),
    ],
)  # fmt: skip
def test_handlers_that_take_their_call_and_plain_values_are_accepted(
    make_node: Any, conn_type: str, options: dict[str, Any]
) -> None:
    node = make_node("handlers_ok")
    agent = node.add_agent(conn_name="ok", conn_type=conn_type, **options)
    assert node.agents == {agent.name: agent}


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


def test_a_bridge_without_xxhash_names_the_extra(
    make_node: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """xxhash is the zenoh extra's too (rmw_zenoh's GIDs): its absence was a bare
    ModuleNotFoundError."""
    for name in [name for name in sys.modules if name.startswith(("xxhash", "pyconnect.ros.zenoh",
                                                                  "pyconnect.transport"))]:  # fmt: skip
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "xxhash", None)
    node = make_node("bridge_without_xxhash")
    with pytest.raises(OptionError) as refused:
        node.add_agent(conn_name="a", conn_type="sub", data_interface=String, transport="zenoh")
    assert str(refused.value) == (
        "agent 'a' (sub): transport='zenoh' needs xxhash: pip install 'pyconnect-ros[zenoh]'"
    )


def test_a_registered_subclass_of_a_kind_calls_its_handler_its_own_way(make_node: Any) -> None:
    """The registration extension point: a sub whose handler takes a count too was refused by
    the base kind's handler shape."""
    from pyconnect.ros.agent_factory import AGENT_CLASS_DICT
    from pyconnect.ros.subscriber_agent import SubscriberAgent

    class CountingSub(SubscriberAgent):
        def __init__(
            self, node: Any, *, conn_name: str, data_interface: Any, response_func: Any,
            agent_name: str | None = None,
        ) -> None:  # fmt: skip
            super().__init__(
                node, conn_name=conn_name, data_interface=data_interface, agent_name=agent_name,
                response_func=lambda value: response_func(value, self.message_count),
            )  # fmt: skip

    AGENT_CLASS_DICT["counting_sub"] = CountingSub
    try:
        node = make_node("counting")
        agent = node.add_agent(
            conn_name="chat",
            conn_type="counting_sub",
            data_interface=String,
            response_func=lambda value, count: None,
        )
        assert isinstance(agent, CountingSub)
    finally:
        del AGENT_CLASS_DICT["counting_sub"]
