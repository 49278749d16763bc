"""ROS names on a peer: rcl's checks and expansion (pyconnect.transport.ros_names), with rclpy's
own validators as the oracle, and a peer's names resolved as a ROS node's are."""

from __future__ import annotations

from typing import Any

import pytest

from pyconnect.errors import PyconnectError
from pyconnect.transport import peer as peer_module
from pyconnect.transport import ros_names
from pyconnect.transport.ros_names import RosNameError
from tests.transport.conftest import PeerFactory

rclpy_expand = pytest.importorskip("rclpy.expand_topic_name").expand_topic_name
rclpy_full = pytest.importorskip("rclpy.validate_full_topic_name").validate_full_topic_name
rclpy_node_name = pytest.importorskip("rclpy.validate_node_name").validate_node_name
rclpy_namespace = pytest.importorskip("rclpy.validate_namespace").validate_namespace

NAMES = [
    "status", "~/status", "~", "/abs", "/abs/deep/name", "a/b", "_a", "a__b", "a/_b", "A9",
    "{node}", "{node}/x", "{ns}/x", "{namespace}", "x/{node}", "{ns}x", "{node}{node}",
    "~a", "~ab", "~/a/b", "/{node}", "{foo}", "{4a}", "{a/b}", "{{a}}", "{a", "a}", "{}",
    "", "/", "cam/", "/cam/", "a b", "1abc", "a/1b", "bad topic!", "a/**", "a$b", "a*b",
    "a//b", "/a//b", "a/~", "/~/a", "é", "a-b", "a.b", "a:b", "x" * 240, "x" * 250,
]  # fmt: skip
NODES = [("vision", "/"), ("vision", "/robot1"), ("n", "/a/b")]


def rclpy_resolve(name: str, node: str, namespace: str) -> str | None:
    """What an rclpy node would use for ``name`` (rcl_node_resolve_name: expand, then check
    the full name), or None when it refuses it."""
    try:
        expanded = rclpy_expand(name, node, namespace)
        rclpy_full(expanded)
    except Exception:
        return None
    return expanded


def our_resolve(name: str, node: str, namespace: str) -> str | None:
    try:
        return ros_names.resolve_name(name, node, namespace)
    except RosNameError:
        return None


@pytest.mark.parametrize(("node", "namespace"), NODES)
@pytest.mark.parametrize("name", NAMES)
def test_names_resolve_as_rclpy_resolves_them(name: str, node: str, namespace: str) -> None:
    assert our_resolve(name, node, namespace) == rclpy_resolve(name, node, namespace)


def rclpy_accepts(check: Any, value: str) -> bool:
    try:
        check(value)
    except Exception:
        return False
    return True


@pytest.mark.parametrize(
    "name",
    [
        *("vision", "_v", "v_2", "V", "", "my-peer", "a b", "a*b", "1abc", "a/b", "é"),
        *("n" * 255, "n" * 256),
    ],
)
def test_node_names_are_checked_as_rclpy_checks_them(name: str) -> None:
    assert (ros_names.node_name_problem(name) is None) == rclpy_accepts(rclpy_node_name, name)


@pytest.mark.parametrize(
    "namespace",
    [
        *("/", "/robot1", "/a/b", "/a/", "//", "/a//b", "/a b*", "/1a", "/a/1b", "/_a", "/a~"),
        *("/" + "n" * 244, "/" + "n" * 245, "/" + "n" * 250),
    ],
)
def test_namespaces_are_checked_as_rclpy_checks_them(namespace: str) -> None:
    ours = ros_names.namespace_problem(namespace) is None
    assert ours == rclpy_accepts(rclpy_namespace, namespace)


def test_a_refused_name_says_which_rule() -> None:
    with pytest.raises(RosNameError) as error:
        ros_names.resolve_name("cam/", "vision", "/robot1")
    assert str(error.value) == "topic name 'cam/' must not end with a forward slash (at index 3)"
    with pytest.raises(RosNameError) as error:
        ros_names.resolve_name("a//b", "vision", "/robot1", kind="service")
    assert str(error.value) == (
        "service name 'a//b' expands to '/robot1/a//b', which must not contain repeated '/' "
        "(at index 10)"
    )
    with pytest.raises(RosNameError) as error:
        ros_names.resolve_name("{foo}/x", "vision", "/robot1")
    assert str(error.value) == (
        "topic name '{foo}/x' has an unknown substitution {foo}; expected one of {node}, {ns}, "
        "{namespace}"
    )


def test_private_and_relative_names_of_a_peer_are_those_of_a_ros_node(
    make_peer: PeerFactory,
) -> None:
    peer = make_peer("vision", namespace="robot1")
    assert peer.namespace == "/robot1"
    kinds = {
        "~/status": ("pub", "std_msgs/msg/String"),
        "scan": ("sub", "std_msgs/msg/String"),
        "~/reset": ("service_server", "std_srvs/srv/Trigger"),
        "/abs": ("service_client", "std_srvs/srv/Trigger"),
    }
    topics = {}
    for name, (conn_type, interface) in kinds.items():
        options: dict[str, Any] = {"conn_name": name, "conn_type": conn_type}
        options["data_interface"] = interface
        if conn_type == "service_server":
            options["response_func"] = lambda _request: {"success": True}
        topics[name] = peer.add_agent(**options).topic
    assert topics == {
        "~/status": "/robot1/vision/status",
        "scan": "/robot1/scan",
        "~/reset": "/robot1/vision/reset",
        "/abs": "/abs",
    }
    for name, topic in topics.items():
        assert topic == rclpy_expand(name, "vision", "/robot1")


@pytest.mark.parametrize(
    ("conn_name", "conn_type", "message"),
    [
        (
            "a/**",
            "pub",
            "agent 'a/**' (pub): topic name 'a/**' must not contain characters other than "
            "alphanumerics, '_', '/', '~', '{' or '}' (at index 2)",
        ),
        (
            "1abc",
            "sub",
            "agent '1abc' (sub): topic name '1abc' must not start with a number (at index 0)",
        ),
        (
            "a$b",
            "service_client",
            "agent 'a$b' (service_client): service name 'a$b' must not contain characters other "
            "than alphanumerics, '_', '/', '~', '{' or '}' (at index 1)",
        ),
    ],
)
def test_a_peer_refuses_an_agent_name_ros_refuses(
    make_peer: PeerFactory, conn_name: str, conn_type: str, message: str
) -> None:
    peer = make_peer("vision")
    interface = "std_srvs/srv/Trigger" if conn_type.startswith("service") else "std_msgs/msg/String"
    with pytest.raises(RosNameError) as error:
        peer.add_agent(conn_name=conn_name, conn_type=conn_type, data_interface=interface)
    assert str(error.value) == message
    assert peer.agents == {}


def test_a_timer_name_is_no_ros_name(make_peer: PeerFactory) -> None:
    peer = make_peer("vision")
    timer = peer.add_agent(
        conn_name="tick every 1s", conn_type="timer", time_period=10.0, response_func=lambda: 0
    )
    assert timer.topic == "tick every 1s"


@pytest.mark.parametrize(
    ("name", "namespace", "message"),
    [
        (
            "a*b",
            "/",
            "peer 'a*b': node name must not contain characters other than alphanumerics or '_' "
            "(at index 1)",
        ),
        (
            "my-peer",
            "/",
            "peer 'my-peer': node name must not contain characters other than alphanumerics or "
            "'_' (at index 2)",
        ),
        ("", "/", "peer '': node name must not be empty"),
        (
            "okp",
            "a b*",
            "peer 'okp': namespace '/a b*' must not contain characters other than "
            "alphanumerics, '_' or '/' (at index 2)",
        ),
        (
            "okp",
            "/robot1/",
            "peer 'okp': namespace '/robot1/' must not end with a '/' (at index 7)",
        ),
    ],
)
def test_a_peer_refuses_its_name_before_opening_a_session(
    monkeypatch: pytest.MonkeyPatch, name: str, namespace: str, message: str
) -> None:
    opened: list[object] = []
    monkeypatch.setattr(peer_module.zenoh, "open", opened.append)
    with pytest.raises(RosNameError) as error:
        peer_module.Peer(name, namespace=namespace, handle_signals=False)
    assert str(error.value) == message
    assert isinstance(error.value, PyconnectError)
    assert opened == []
