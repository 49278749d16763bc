"""The agent API as the design writes it: config dicts, options per kind, rclpy's Node methods,
``listen(run_thread=)``, ``publish``; and ``ros/`` without import circles or private reaches."""

from __future__ import annotations

import ast
import threading
from pathlib import Path
from typing import Any

import pytest
import rclpy.node
from std_msgs.msg import String
from std_srvs.srv import Trigger
from test_msgs.action import Fibonacci

from pyconnect.errors import PyconnectError
from pyconnect.ros.agent_factory import AGENT_CLASS_DICT, make_agent, options_of
from pyconnect.ros.agent_options import AgentOptions, OptionError
from pyconnect.ros.custom_node import CustomNode

from .conftest import EVENT_TIMEOUT, repeat_until

ROS_PACKAGE = Path(__file__).resolve().parents[2] / "src" / "pyconnect" / "ros"

# A valid config per kind, and an option of AgentOptions that kind does not use.
VALID = {
    "sub": {"data_interface": String},
    "pub": {"data_interface": String},
    "service_client": {"data_interface": Trigger},
    "service_server": {"data_interface": Trigger, "response_func": lambda _r: {}},
    "action_client": {"data_interface": Fibonacci},
    "action_server": {"data_interface": Fibonacci, "response_func": lambda _g: {}},
    "timer": {"time_period": 1.0, "response_func": lambda: None},
}
UNUSED = {
    "sub": "time_period",
    "pub": "stamped",
    "service_client": "response_func",
    "service_server": "qos",
    "action_client": "time_period",
    "action_server": "accepted_func",
    "timer": "data_interface",
}


def test_make_agent_takes_the_designs_config_dict(make_node: Any) -> None:
    node = make_node()
    agent = make_agent(node, {"conn_name": "chatter", "conn_type": "pub", "data_interface": String})
    assert agent.topic == "/chatter"
    # The node owns it (DESIGN: make_agent(node, {...}); node.listen(...)): it was built but
    # left out of node.agents, so wait_until_connected ignored it and shutdown never closed it.
    assert node.agents["chatter"] is agent
    # The dict and keywords mix; keywords win.
    other = node.add_agent(
        {"conn_name": "x", "conn_type": "sub", "data_interface": Trigger},
        data_interface="std_msgs/String",
    )
    assert other.type_name == "std_msgs/msg/String"
    assert node.agents["x"] is other


@pytest.mark.parametrize("kind", sorted(AGENT_CLASS_DICT))
def test_every_kind_rejects_an_option_it_does_not_use(make_node: Any, kind: str) -> None:
    node = make_node()
    config = {"conn_name": "c", "conn_type": kind, **VALID[kind]}
    option = UNUSED[kind]
    with pytest.raises(TypeError) as caught:
        node.add_agent(config, **{option: 1.0})
    assert isinstance(caught.value, OptionError)
    assert str(caught.value) == (
        f"agent 'c' ({kind}): option {option!r} is not used by a {kind!r} agent"
    )
    assert node.add_agent(config).conn_type == kind


def test_missing_and_unknown_options_name_the_option(make_node: Any) -> None:
    node = make_node()
    with pytest.raises(OptionError) as caught:
        make_agent(node, {"conn_name": "t", "conn_type": "timer", "time_period": 1.0})
    assert str(caught.value) == "agent 't' (timer): missing option 'response_func'"
    with pytest.raises(OptionError) as caught:
        make_agent(node, {"conn_name": "s", "conn_type": "sub", "data_interface": String, "fsp": 1})
    assert str(caught.value) == "agent 's' (sub): unknown option 'fsp'"
    with pytest.raises(OptionError) as caught:
        make_agent(node, {"conn_type": "sub", "data_interface": String})
    assert str(caught.value) == "agent config: conn_name must be a non-empty str, got None"


def test_agent_options_list_every_option_of_every_kind() -> None:
    declared = set(AgentOptions.__annotations__)
    for agent_class in AGENT_CLASS_DICT.values():
        accepted, _required = options_of(agent_class)
        assert accepted <= declared, agent_class


def test_custom_node_is_an_rclpy_node(make_node: Any) -> None:
    node = make_node(cli_args=["--ros-args", "-p", "rate:=7"])
    assert isinstance(node, rclpy.node.Node)
    assert node.ros_node is node
    assert node.get_name() == "test_node"
    # rclpy's own rules: an override is the value of the parameter declared with its name.
    assert node.declare_parameter("rate", 5).value == 7
    assert node.get_parameter("rate").value == 7
    node.declare_parameter("gain", 0.5)
    assert node.get_parameter("gain").value == 0.5
    assert node.get_clock().now().nanoseconds > 0
    node.get_logger().info("rclpy's logger works")
    heard = threading.Event()
    node.create_subscription(String, "plain", lambda _msg: heard.set(), 10)
    publisher = node.create_publisher(String, "plain", 10)
    node.spin(run_thread=True)
    assert repeat_until(heard, lambda: publisher.publish(String(data="x")))


def test_listen_takes_run_thread_and_publish_is_send(make_node: Any) -> None:
    node = make_node()
    heard: list[str] = []
    arrived = threading.Event()
    node.add_agent(
        conn_name="chatter",
        conn_type="sub",
        data_interface=String,
        response_func=lambda value: (heard.append(value), arrived.set()),
    )
    pub = node.add_agent(
        conn_name="chatter", agent_name="out", conn_type="pub", data_interface=String
    )
    node.listen(run_thread=True)
    assert node.is_spinning
    assert repeat_until(arrived, lambda: pub.publish("via publish"))
    assert heard[0] == "via publish"


def test_destroy_node_shuts_down_once(make_node: Any) -> None:
    calls: list[int] = []
    node: CustomNode = make_node(stop_func=lambda: calls.append(1))
    node.spin(run_thread=True)
    node.destroy_node()
    assert node.wait_for_shutdown(EVENT_TIMEOUT)
    assert calls == [1]


def _ros_imports(path: Path) -> set[str]:
    """The pyconnect.ros modules ``path`` imports, anywhere in it (also inside functions)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        for name in names:
            if name.startswith("pyconnect.ros.") and (ROS_PACKAGE / f"{name[14:]}.py").exists():
                found.add(name[14:])
    return found


def test_ros_modules_import_each_other_without_circles() -> None:
    graph = {path.stem: _ros_imports(path) for path in ROS_PACKAGE.glob("*.py")}
    visiting: list[str] = []
    done: set[str] = set()

    def visit(module: str) -> None:
        if module in done:
            return
        assert module not in visiting, " -> ".join([*visiting, module])
        visiting.append(module)
        for imported in sorted(graph[module]):
            visit(imported)
        visiting.pop()
        done.add(module)

    for module in sorted(graph):
        visit(module)


# wait_plan.py replaces rclpy's ``Executor._wait_for_ready_callbacks`` (a hook rclpy names
# private) and so reads, with wait_entries.py, the state that rclpy's own version reads;
# nothing else may.
RCLPY_WAIT_INTERNALS = {
    "_active_entity",
    "_executor_event",
    "_executor_triggered",
    "_guard",
    "_is_shutdown",
    "_make_handler",
    "_sigint_gc",
    "_take_client",
    "_take_guard_condition",
    "_take_service",
    "_take_subscription",
    "_take_timer",
    "_take_waitable",
    "_tasks",
    "_tasks_lock",
}


WAIT_MODULES = ("wait_plan.py", "wait_entries.py")


def test_ros_modules_reach_no_private_attribute_of_another_module() -> None:
    reaches = []
    for path in sorted(ROS_PACKAGE.glob("*.py")):
        tree = ast.parse(path.read_text())
        own = {
            node.name
            for node in ast.walk(tree)
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        } | {
            node.attr
            for node in ast.walk(tree)
            if isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id == "self"
        }
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Attribute) and node.attr.startswith("_")):
                continue
            if node.attr.startswith("__") or node.attr in own:
                continue
            if path.name in WAIT_MODULES and node.attr in RCLPY_WAIT_INTERNALS:
                continue
            if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                continue
            reaches.append(f"{path.name}:{node.lineno} {ast.unparse(node)}")
    assert reaches == []


def test_shared_options_apply_to_the_kinds_that_use_them(make_node: Any) -> None:
    node = make_node()
    sub, timer = node.add_agents(
        [
            {"conn_name": "chatter", "conn_type": "sub", "data_interface": String},
            {"conn_name": "beat", "conn_type": "timer", "time_period": 1.0,
             "response_func": lambda: None},
        ],
        do_log_msg=True,
    )  # fmt: skip
    assert sub.do_log_msg is True
    assert timer.do_log_msg is False
    with pytest.raises(OptionError) as caught:
        node.add_agents([{"conn_name": "x", "conn_type": "sub", "data_interface": String}], fsp=1)  # type: ignore[call-arg]
    assert str(caught.value) == "agent 'x' (sub): unknown option 'fsp'"


BAD_PERIODS = [0, -1.0, float("nan"), float("inf"), "1", True]
"""Periods no timer may have (a pub without one is fine: it publishes on send())."""


@pytest.mark.parametrize(
    ("kind", "period"),
    [(kind, p) for kind in ("timer", "pub") for p in BAD_PERIODS],
    ids=repr,
)
def test_a_period_that_is_not_a_finite_positive_number_is_refused(
    make_node: Any, kind: str, period: object
) -> None:
    """NaN passed the old ``<= 0`` check; inf and NaN reached rclpy, whose error names no
    agent; a string failed with a bare TypeError."""
    node = make_node()
    config = {"conn_name": "beat", "conn_type": kind, **VALID[kind], "time_period": period}
    if kind == "pub":
        config["response_func"] = lambda: "x"
    with pytest.raises(PyconnectError) as caught:
        node.add_agent(config)
    described = "pub std_msgs/msg/String" if kind == "pub" else kind
    assert str(caught.value) == (
        f"agent 'beat' ({described}): time_period must be a finite number of seconds > 0, "
        f"got {period!r}"
    )


def test_a_timer_period_given_as_none_is_missing(make_node: Any) -> None:
    """A required option given as None is missing, as response_func=None is."""
    node = make_node()
    with pytest.raises(OptionError) as caught:
        node.add_agent(conn_name="beat", conn_type="timer", time_period=None, response_func=print)
    assert str(caught.value) == "agent 'beat' (timer): missing option 'time_period'"


@pytest.mark.parametrize("kind", ["timer", "pub"])
def test_a_period_longer_than_a_ros_timer_holds_is_refused(make_node: Any, kind: str) -> None:
    """rclpy's int64 nanoseconds cannot hold 1e10 s: a pybind TypeError naming nothing."""
    node = make_node()
    config = {"conn_name": "beat", "conn_type": kind, **VALID[kind], "time_period": 1e10}
    if kind == "pub":
        config["response_func"] = lambda: "x"
    with pytest.raises(PyconnectError) as caught:
        node.add_agent(config)
    described = "pub std_msgs/msg/String" if kind == "pub" else kind
    assert str(caught.value) == (
        f"agent 'beat' ({described}): time_period must be at most 9.22e+09 seconds, "
        "got 10000000000.0"
    )
    assert node.agents == {}
