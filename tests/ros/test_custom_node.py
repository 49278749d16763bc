"""CustomNode: the agent factory, names, QoS, waiting for connections, timers, add_agents."""

from __future__ import annotations

import math
import threading
from typing import Any

import pytest
import rclpy.exceptions
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import String
from std_srvs.srv import Trigger

from pyconnect.errors import ConnectionTimeout, PyconnectError
from pyconnect.ros.agent_factory import AGENT_CLASS_DICT, make_agent
from pyconnect.ros.agent_options import OptionError
from pyconnect.ros.node_agent import NodeAgent
from pyconnect.ros.qos import follows_publishers, resolve_qos

from .conftest import EVENT_TIMEOUT, repeat_until


def test_unknown_conn_type_is_a_clear_error(make_node: Any) -> None:
    node = make_node()
    with pytest.raises(PyconnectError) as caught:
        node.add_agent(conn_name="cam", conn_type="subscriber", data_interface=Image)
    assert str(caught.value) == (
        "agent 'cam': unknown conn_type 'subscriber'; expected one of 'sub', 'pub', "
        "'service_client', 'service_server', 'action_client', 'action_server', 'timer'"
    )


def test_unknown_option_is_a_clear_error(make_node: Any) -> None:
    node = make_node()
    with pytest.raises(TypeError) as caught:
        node.add_agent(conn_name="cam", conn_type="sub", data_interface=Image, fps=3)  # type: ignore[call-arg]
    assert str(caught.value) == "agent 'cam' (sub): unknown option 'fps'"


def test_wrong_interface_kind_is_a_clear_error(make_node: Any) -> None:
    node = make_node()
    with pytest.raises(PyconnectError) as caught:
        node.add_agent(conn_name="x", conn_type="pub", data_interface=Trigger)
    assert str(caught.value) == (
        "agent 'x' (pub): std_srvs/srv/Trigger: expected a message type, got a service type"
    )


def test_duplicate_agent_name(make_node: Any) -> None:
    node = make_node()
    node.add_agent(conn_name="chatter", conn_type="pub", data_interface=String)
    with pytest.raises(PyconnectError) as caught:
        node.add_agent(conn_name="chatter", conn_type="sub", data_interface=String)
    assert str(caught.value) == (
        "agent 'chatter': node '/test_node' already has an agent of that name; "
        "give one of them agent_name="
    )


def test_interface_by_name_and_add_agents_shared_options(make_node: Any) -> None:
    node = make_node()
    agents = node.add_agents(
        [{"conn_name": "a"}, {"conn_name": "b", "qos": "sensor_data"}],
        conn_type="pub",
        data_interface="std_msgs/String",
    )
    assert [agent.name for agent in agents] == ["a", "b"]
    assert node.agents["a"].type_name == "std_msgs/msg/String"
    assert node.agents["b"].publisher.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT


def test_names_resolve_in_the_namespace_and_remap(make_node: Any) -> None:
    node = make_node("robot", namespace="/ns", cli_args=["--ros-args", "-r", "chatter:=talk"])
    relative = node.add_agent(conn_name="chatter", conn_type="pub", data_interface=String)
    absolute = node.add_agent(conn_name="/status", conn_type="pub", data_interface=String)
    private = node.add_agent(conn_name="~/debug", conn_type="pub", data_interface=String)
    assert relative.topic == "/ns/talk"
    assert absolute.topic == "/status"
    assert private.topic == "/ns/robot/debug"


def test_parameters_from_the_command_line(make_node: Any) -> None:
    node = make_node(cli_args=["--ros-args", "-p", "speed:=0.5"])
    assert node.get_param("speed") == 0.5
    assert node.get_param("missing", 3) == 3


def test_qos_names_and_sensor_defaults() -> None:
    assert resolve_qos("latched", msg_type="std_msgs/msg/String", publisher=True).durability == (
        DurabilityPolicy.TRANSIENT_LOCAL
    )
    # A sensor sub agent follows its publishers (tests/ros/test_sensor_qos.py); a subscription
    # that cannot follow them (the zenoh bridge's) stays best effort, which hears every driver.
    assert follows_publishers(None, msg_type="sensor_msgs/msg/LaserScan")
    assert not follows_publishers("sensor_data", msg_type="sensor_msgs/msg/LaserScan")
    assert not follows_publishers(None, msg_type="std_msgs/msg/String")
    sensor_sub = resolve_qos(None, msg_type="sensor_msgs/msg/LaserScan", publisher=False)
    sensor_pub = resolve_qos(None, msg_type="sensor_msgs/msg/Image", publisher=True)
    assert sensor_sub.reliability == ReliabilityPolicy.BEST_EFFORT
    assert sensor_pub.reliability == ReliabilityPolicy.RELIABLE
    profile = QoSProfile(depth=3)
    assert resolve_qos(profile, msg_type="x/msg/Y", publisher=True) is profile
    with pytest.raises(PyconnectError) as caught:
        resolve_qos("fast", msg_type="x/msg/Y", publisher=True)
    assert str(caught.value) == (
        "qos: unknown profile 'fast'; expected a QoSProfile or one of 'default', "
        "'sensor_data', 'latched'"
    )


def test_sensor_sub_is_reliable_and_hears_a_reliable_driver(make_node: Any) -> None:
    node = make_node()
    arrived = threading.Event()
    sub = node.add_agent(
        conn_name="scan",
        conn_type="sub",
        data_interface=LaserScan,
        decode_func=lambda msg: msg,
        response_func=lambda _msg: arrived.set(),
    )
    # No publisher yet: reliable, so no large frame is dropped (a best-effort one appearing
    # later switches it: tests/ros/test_sensor_qos.py).
    assert sub.subscription.qos_profile.reliability == ReliabilityPolicy.RELIABLE
    driver = node.ros_node.create_publisher(LaserScan, "scan", 10)  # reliable, as drivers do
    node.spin(run_thread=True)
    assert repeat_until(arrived, lambda: driver.publish(LaserScan()))
    assert sub.subscription.qos_profile.reliability == ReliabilityPolicy.RELIABLE


def test_wait_until_connected_names_the_agents_still_waiting(make_node: Any) -> None:
    node = make_node()
    node.add_agent(conn_name="camera", conn_type="sub", data_interface=Image)
    node.add_agent(conn_name="get_map", conn_type="service_client", data_interface=Trigger)
    node.spin(run_thread=True)
    with pytest.raises(ConnectionTimeout) as caught:
        node.wait_until_connected(timeout=0.1)
    assert str(caught.value) == (
        "node '/test_node': still waiting after 0.1 s for agent 'camera' (sub "
        "sensor_msgs/msg/Image) (no message yet), agent 'get_map' (service_client "
        "std_srvs/srv/Trigger) (no server yet)"
    )


def test_errors_name_the_node_as_remapped_and_namespaced(make_node: Any) -> None:
    node = make_node(
        "camera", cli_args=["--ros-args", "-r", "__node:=left_cam", "-r", "__ns:=/robot1"]
    )
    node.add_agent(conn_name="trigger", conn_type="sub", data_interface=String)
    with pytest.raises(PyconnectError) as duplicate:
        node.add_agent(conn_name="trigger", conn_type="sub", data_interface=String)
    assert str(duplicate.value) == (
        "agent 'trigger': node '/robot1/left_cam' already has an agent of that name; "
        "give one of them agent_name="
    )
    with pytest.raises(ConnectionTimeout) as waited:
        node.wait_until_connected(timeout=0.1)
    assert str(waited.value) == (
        "node '/robot1/left_cam': still waiting after 0.1 s for agent 'trigger' (sub "
        "std_msgs/msg/String) (no message yet)"
    )
    node.shutdown()
    assert node.get_fully_qualified_name() == "/robot1/left_cam"  # also once shut down
    with pytest.raises(PyconnectError) as added:
        node.add_agent(conn_name="x", conn_type="pub", data_interface=String)
    assert str(added.value) == "node '/robot1/left_cam' is shut down; cannot add 'x'"
    with pytest.raises(PyconnectError) as spun:
        node.spin(run_thread=True)
    assert str(spun.value) == "node '/robot1/left_cam' is shut down"


def test_wait_until_connected_returns_when_everything_is_there(make_node: Any) -> None:
    node = make_node()
    node.add_agent(conn_name="status", conn_type="sub", data_interface=String, qos="latched")
    node.add_agent(
        conn_name="status", agent_name="out", conn_type="pub", data_interface=String, qos="latched"
    )
    node.add_agent(
        conn_name="ping",
        conn_type="service_server",
        data_interface=Trigger,
        response_func=lambda _request: {"success": True},
    )
    node.add_agent(
        conn_name="ping",
        agent_name="ping_client",
        conn_type="service_client",
        data_interface=Trigger,
    )
    node.agents["out"].send("ready")
    node.spin(run_thread=True)
    node.wait_until_connected(timeout=EVENT_TIMEOUT)
    assert node.agents["status"].get() == "ready"


def test_timer_calls_response_func_and_survives_errors(make_node: Any) -> None:
    node = make_node()
    ticks: list[int] = []
    three = threading.Event()

    def tick() -> int:
        ticks.append(1)
        if len(ticks) == 1:
            raise RuntimeError("first tick fails")
        if len(ticks) >= 3:
            three.set()
        return len(ticks)

    timer = node.add_agent(
        conn_name="heartbeat", conn_type="timer", time_period=0.01, response_func=tick
    )
    node.spin(run_thread=True)
    assert three.wait(EVENT_TIMEOUT)
    assert timer.error_count == 1
    assert (
        timer.last_error
        == "agent 'heartbeat' (timer): response_func raised RuntimeError: first tick fails"
    )
    assert timer.get() >= 2
    with pytest.raises(PyconnectError) as caught:
        timer.send(1)
    assert (
        str(caught.value) == "agent 'heartbeat' (timer): send() is not available on a 'timer' agent"
    )


def test_reform_response_contract() -> None:
    assert NodeAgent.reform_response({"a": 1}) == {"a": 1, "isdone": True}
    assert NodeAgent.reform_response(5) == 5
    assert NodeAgent.reform_response(None, error="timed out") == {
        "isdone": False,
        "error": "timed out",
    }
    assert NodeAgent.reform_response({"a": 1}, error="aborted") == {
        "a": 1,
        "isdone": False,
        "error": "aborted",
    }


def test_new_agent_kinds_plug_into_the_factory(make_node: Any) -> None:
    class EchoAgent(NodeAgent):
        conn_type = "echo"

        def send(self, data: Any = None) -> Any:
            self._latest = data
            return data

    AGENT_CLASS_DICT["echo"] = EchoAgent
    try:
        node = make_node()
        agent = make_agent(node, conn_name="e", conn_type="echo")
        assert agent.send(3) == 3
        assert agent.get() == 3
        assert agent.describe == "agent 'e' (echo)"
    finally:
        del AGENT_CLASS_DICT["echo"]


def test_stop_func_runs_once_on_shutdown(make_node: Any) -> None:
    calls: list[int] = []
    node = make_node(stop_func=lambda: calls.append(1))
    node.spin(run_thread=True)
    node.shutdown()
    node.shutdown()
    assert calls == [1]
    assert not node.ok()
    with pytest.raises(PyconnectError):
        node.add_agent(conn_name="late", conn_type="pub", data_interface=String)


def test_get_show_info_returns_the_value(make_node: Any) -> None:
    node = make_node()
    pub = node.add_agent(conn_name="note", conn_type="pub", data_interface=String)
    pub.send("hi")
    assert pub.get(show_info=True) == "hi"
    assert pub.info_text() == "agent 'note' (pub std_msgs/msg/String): latest 'hi'"


def test_add_agent_while_shutdown_destroys_the_agents_is_refused(
    make_node: Any, monkeypatch: Any
) -> None:
    """Another thread adding an agent while the node's entities are being destroyed gets the
    node's own error, not rclpy's (and no agent that nobody would close)."""
    node = make_node("closing_node")
    agent = node.add_agent(conn_name="chatter", conn_type="pub", data_interface=String)
    outcome: list[BaseException | None] = []

    def add_from_another_thread() -> None:
        try:
            node.add_agent(conn_name="late", conn_type="pub", data_interface=String)
            outcome.append(None)
        except BaseException as error:
            outcome.append(error)

    close = agent.close

    def close_while_another_thread_adds() -> None:
        adder = threading.Thread(target=add_from_another_thread)
        adder.start()
        adder.join(EVENT_TIMEOUT)
        close()

    monkeypatch.setattr(agent, "close", close_while_another_thread_adds)
    node.shutdown()
    assert len(outcome) == 1
    assert isinstance(outcome[0], PyconnectError)
    assert str(outcome[0]) == "node '/closing_node' is shut down; cannot add 'late'"
    assert "late" not in node.agents


def test_a_failing_shutdown_step_is_reported_and_the_rest_still_run(
    make_node: Any, monkeypatch: Any
) -> None:
    node = make_node("failing_step")
    node.add_agent(conn_name="chatter", conn_type="pub", data_interface=String)
    node.spin(run_thread=True)

    def broken_stop(timeout: float | None = 5.0) -> None:
        raise RuntimeError("the loop is broken")

    monkeypatch.setattr(node.coroutines, "stop", broken_stop)
    errors: list[str] = []
    monkeypatch.setattr(node, "_log_error", errors.append)
    node.shutdown()
    assert errors == [
        "shutdown: stopping the coroutine loop failed: RuntimeError: the loop is broken"
    ]
    assert node.wait_for_shutdown(0)
    assert not node.context.ok()  # the node was destroyed and left its context
    assert not node.is_spinning


def test_shutdown_from_a_plain_callback_returns_at_once_and_spin_returns(make_node: Any) -> None:
    node = make_node("timer_stopper")
    down_in_callback: list[bool] = []

    def tick() -> None:
        if not down_in_callback:
            node.shutdown()
            down_in_callback.append(node.wait_for_shutdown(0))

    node.add_agent(conn_name="tick", conn_type="timer", time_period=0.01, response_func=tick)
    spun = threading.Thread(target=node.spin)  # spin() blocking, as a main thread would
    spun.start()
    spun.join(EVENT_TIMEOUT)
    assert not spun.is_alive()
    assert down_in_callback == [False]  # it did not wait for (nor destroy the node under) tick
    assert not node.context.ok()


def test_stop_func_may_still_add_an_agent_and_record(make_node: Any, tmp_path: Any) -> None:
    """stop_func runs "while the agents still work": adding a last agent or a recording there
    worked before shutdown refused new entities from its first step; what it starts stops."""
    made: dict[str, Any] = {}

    def last_words() -> None:
        made["pub"] = node.add_agent(conn_name="goodbye", conn_type="pub", data_interface=String)
        made["recording"] = node.record(tmp_path / "last", topics=["/goodbye"])
        made["sent"] = made["pub"].send("bye")

    node = make_node("last_words", stop_func=last_words)
    node.spin(run_thread=True)
    node.shutdown()
    assert made["sent"] is not False and node.agents["goodbye"] is made["pub"]
    # Stopped with the node, after stop_func: the file is complete.
    (mcap,) = (tmp_path / "last").glob("*.mcap")
    assert mcap.read_bytes().endswith(b"\x89MCAP0\r\n")


def test_shutting_another_node_down_from_a_callback_waits_for_it(make_node: Any) -> None:
    """Only a node's own callback threads defer its shutdown; from another node's callback it
    returns when that node is down (leaving `with` inside a callback closes that node)."""
    outer, inner = make_node("outer_ticker"), make_node("inner_helper")
    inner.spin(run_thread=True)
    seen: list[bool] = []
    done = threading.Event()

    def tick() -> None:
        if not done.is_set():
            inner.shutdown()
            seen.append(inner.wait_for_shutdown(0))  # all the way down, not merely begun
            done.set()

    outer.add_agent(conn_name="tick", conn_type="timer", time_period=0.01, response_func=tick)
    outer.spin(run_thread=True)
    assert done.wait(EVENT_TIMEOUT)
    assert seen == [True]


def test_a_codec_of_another_type_is_refused_when_the_agent_is_made(make_node: Any) -> None:
    # It was accepted, and send() then failed in rclpy's words ("Expected Twist, got Image").
    from geometry_msgs.msg import Twist

    from pyconnect.codecs.image import ImageCodec

    node = make_node("codec_check")
    with pytest.raises(PyconnectError) as caught:
        node.add_agent(conn_name="cmd", conn_type="pub", data_interface=Twist, codec=ImageCodec())
    assert "codec: ImageCodec converts 'sensor_msgs/msg/Image', expected a codec of " in str(
        caught.value
    )
    assert "'geometry_msgs/msg/Twist'" in str(caught.value)


def test_add_agents_refuses_one_dict_or_a_list_of_non_dicts(make_node: Any) -> None:
    # One dict was iterated as its keys: "'str' object has no attribute 'get'".
    node = make_node("add_agents_shape")
    with pytest.raises(OptionError) as one:
        node.add_agents({"conn_name": "g", "conn_type": "pub", "data_interface": String})  # type: ignore[arg-type]
    expected = "expected a list of agent dicts, got dict; for one agent call add_agent(config)"
    assert str(one.value) == f"add_agents: {expected}"
    with pytest.raises(OptionError) as text:
        node.add_agents("g")  # type: ignore[arg-type]
    assert str(text.value) == "add_agents: expected a list of agent dicts, got str"
    with pytest.raises(OptionError) as number:
        node.add_agents(5)  # type: ignore[arg-type]
    assert str(number.value) == "add_agents: expected a list of agent dicts, got int"
    with pytest.raises(OptionError) as item:
        node.add_agents([{"conn_name": "g", "conn_type": "pub", "data_interface": String}, "h"])  # type: ignore[list-item]
    assert str(item.value) == "add_agents: configs[1]: expected an agent dict, got str"
    assert not node.agents  # checked before any agent was made


def test_parameters_follow_rclpys_rules_with_overrides(make_node: Any) -> None:
    """Overrides were declared automatically: ``declare_parameter`` of an overridden name
    raised ParameterAlreadyDeclaredException (the standard pattern broke the first time
    someone passed ``-p``), and a misspelt ``get_parameter`` returned an unset value."""
    node = make_node("params", cli_args=["--ros-args", "-p", "rate:=10.0", "-p", "mode:=fast"])
    assert node.get_param("rate") == 10.0  # read before any declaration
    assert node.declare_parameter("rate", 5.0).value == 10.0
    assert [p.value for p in node.declare_parameters("", [("mode", "slow"), ("gain", 2)])] == [
        "fast",
        2,
    ]
    with pytest.raises(rclpy.exceptions.ParameterNotDeclaredException):
        node.get_parameter("rtae")
    assert node.get_param("rtae", 1.5) == 1.5


@pytest.mark.parametrize("timeout", ["2", -1, math.nan, True])
def test_wait_until_connected_refuses_a_timeout_that_is_not_one(
    make_node: Any, timeout: object
) -> None:
    node = make_node("waiter")
    with pytest.raises(PyconnectError, match=r"^node '/waiter': wait_until_connected: timeout"):
        node.wait_until_connected(timeout)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("options", "problem"),
    [
        ({"registry": "r"}, "registry: expected a pyconnect Registry or None, got 'r'"),
        (
            {"stop_func": "stop"},
            "stop_func: expected a callable or None, got 'stop'; pass the function itself, "
            "not its name",
        ),
        (
            {"stop_func": lambda reason: None},
            "stop_func: shutdown calls it with no arguments, but it requires 'reason'",
        ),
        ({"handoff_after": -1}, "handoff_after must be a finite number of seconds >= 0, got -1"),
        (
            {"handoff_after": math.nan},
            "handoff_after must be a finite number of seconds >= 0, got nan",
        ),
        (
            {"handoff_after": "0.1"},
            "handoff_after must be a finite number of seconds >= 0, got '0.1'",
        ),
        ({"handle_signals": "no"}, "handle_signals: expected bool, got 'no'"),
        ({"log_dir": 5}, "log_dir: expected a str, a Path or None, got 5"),
    ],
)
def test_a_keyword_the_node_cannot_use_is_refused_naming_it(
    make_node: Any, options: dict[str, Any], problem: str
) -> None:
    """A str registry failed at the first agent (AttributeError), a str stop_func only in
    shutdown's log, and a negative handoff_after was taken."""
    threads = threading.active_count()
    with pytest.raises(OptionError) as refused:
        make_node("keywords", **options)
    assert str(refused.value) == f"node 'keywords': {problem}"
    assert threading.active_count() == threads  # refused before anything started


def test_the_keywords_take_what_they_document(make_node: Any, tmp_path: Any) -> None:
    import functools

    from pyconnect.codecs.registry import Registry

    stopped: list[str] = []
    node = make_node(
        "keywords_ok",
        registry=Registry(),
        stop_func=functools.partial(stopped.append, "done"),
        handoff_after=0,
        log_dir=str(tmp_path),
    )
    node.shutdown()
    assert stopped == ["done"]


def test_a_stop_func_that_calls_shutdown_does_not_deadlock(make_node: Any) -> None:
    """A stop_func shared with other clean-up code called node.shutdown() and hung for ever."""
    import threading

    calls: list[bool] = []
    node = make_node("twice")

    def stop() -> None:
        calls.append(True)
        node.shutdown()

    node.stop_func = stop
    done = threading.Thread(target=node.shutdown, daemon=True)
    done.start()
    done.join(30)
    assert not done.is_alive()
    assert calls == [True]
