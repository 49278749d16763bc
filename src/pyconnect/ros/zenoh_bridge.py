"""``add_agent(..., transport='zenoh')``: forward one topic between the ROS graph and zenoh peers.

``conn_type`` names the ROS side. ``'sub'`` subscribes to the ROS topic and republishes every
message on zenoh; ``'pub'`` publishes on ROS what zenoh peers publish. Messages cross as the
CDR bytes they already are (rclpy's raw subscription and ``publish(bytes)``): nothing is
decoded on the way, but what comes from zenoh is read as a zero-copy view first, so a malformed
sample is reported at the bridge and not published; ``get()`` decodes the latest one on
demand. On zenoh the topic has the ROS name and rmw_zenoh's key, attachment and tokens
(pyconnect.transport), so peers and ROS nodes running rmw_zenoh see it as usual.

All bridged agents of one node share one ``Peer`` named as the node, opened with the zenoh
configuration rmw_zenoh reads (``ZENOH_SESSION_CONFIG_URI``, ``ZENOH_CONFIG_OVERRIDE``) in the
domain ``ROS_DOMAIN_ID``; it closes with the last of them.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import threading
import time
import weakref
from typing import Any

from rclpy.qos import QoSProfile

from pyconnect.codecs import wire
from pyconnect.errors import PyconnectError
from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.interfaces import interface_class
from pyconnect.ros.node_agent import NodeAgent
from pyconnect.ros.qos import resolve_qos
from pyconnect.transport.peer import Peer
from pyconnect.transport.topic_publisher import PublisherAgent
from pyconnect.transport.topic_subscriber import SubscriberAgent

_peers_lock = threading.Lock()
_peers: weakref.WeakKeyDictionary[Any, tuple[Peer, int]] = weakref.WeakKeyDictionary()


def _acquire_peer(node: AgentHost) -> Peer:
    with _peers_lock:
        found = _peers.get(node)
        if found is None:
            peer = Peer(
                node.name,
                namespace=node.ros_node.get_namespace(),
                registry=node.registry,
                handle_signals=False,
            )
            found = (peer, 0)
        _peers[node] = (found[0], found[1] + 1)
        return found[0]


def _release_peer(node: AgentHost) -> None:
    with _peers_lock:
        found = _peers.get(node)
        if found is None:
            return
        peer, users = found
        if users > 1:
            _peers[node] = (peer, users - 1)
            return
        del _peers[node]
    peer.shutdown()


class _BridgeAgent(NodeAgent):
    def __init__(self, node: AgentHost, *, conn_name: str, agent_name: str | None, msg_class: type):
        super().__init__(node, conn_name=conn_name, agent_name=agent_name, data_interface=msg_class)
        self.forwarded_count = 0
        self.last_forwarded_ns = 0
        self._latest_bytes: bytes | None = None
        self._wire = self.peer_side_codec()

    def peer_side_codec(self) -> Any:
        from pyconnect.codecs import wire

        return wire.wire_codec(self.type_name)

    def _forwarded(self, payload: bytes) -> None:
        self._latest_bytes = payload
        self.forwarded_count += 1
        self.last_forwarded_ns = time.time_ns()

    def get(self, show_info: bool = False) -> Any:
        """The natural value of the latest forwarded message (decoded now); None before any."""
        payload = self._latest_bytes
        value = None if payload is None else self._wire.decode(payload, registry=self.node.registry)
        if show_info:
            self.node.get_logger().info(f"{self.describe}: {self.forwarded_count} forwarded")
        return value


class RosToZenohAgent(_BridgeAgent):
    """Subscribes on ROS and republishes each message's CDR bytes on zenoh."""

    conn_type = "sub"

    def __init__(
        self,
        node: AgentHost,
        *,
        conn_name: str,
        agent_name: str | None = None,
        data_interface: object,
        qos: QoSProfile | str | int | None = None,
    ) -> None:
        msg_class = interface_class(data_interface, kind="msg")
        super().__init__(node, conn_name=conn_name, agent_name=agent_name, msg_class=msg_class)
        self.subscription = node.ros_node.create_subscription(
            msg_class,
            conn_name,
            self._on_message,
            resolve_qos(qos, msg_type=self.type_name, publisher=False),
            callback_group=self.callback_group,
            raw=True,
        )
        self.topic = self.subscription.topic_name
        self.peer = _acquire_peer(node)
        self.zenoh_publisher = PublisherAgent(
            self.peer, conn_name=self.topic, data_interface=self.type_name, raw=True
        )

    def _on_message(self, payload: bytes) -> None:
        try:
            self.zenoh_publisher.send(payload)
        except Exception as error:
            self.report_exception("zenoh publish", error)
            return
        self._forwarded(payload)

    def close(self) -> None:
        self.node.ros_node.destroy_subscription(self.subscription)
        self.zenoh_publisher.close()
        _release_peer(self.node)
        super().close()


class ZenohToRosAgent(_BridgeAgent):
    """Subscribes on zenoh and publishes each sample's CDR bytes on ROS."""

    conn_type = "pub"

    def __init__(
        self,
        node: AgentHost,
        *,
        conn_name: str,
        agent_name: str | None = None,
        data_interface: object,
        qos: QoSProfile | str | int | None = None,
    ) -> None:
        msg_class = interface_class(data_interface, kind="msg")
        super().__init__(node, conn_name=conn_name, agent_name=agent_name, msg_class=msg_class)
        self.publisher = node.ros_node.create_publisher(
            msg_class,
            conn_name,
            resolve_qos(qos, msg_type=self.type_name, publisher=True),
            callback_group=self.callback_group,
        )
        self.topic = self.publisher.topic_name
        self.peer = _acquire_peer(node)
        self.zenoh_subscriber = SubscriberAgent(
            self.peer,
            conn_name=self.topic,
            data_interface=self.type_name,
            raw=True,
            response_func=self._on_sample,
        )
        # Read (zero-copy views, microseconds even for an image) before it goes on ROS: a
        # malformed sample is reported here, where it came in, instead of being handed to
        # every ROS subscriber to fail on.
        self._check = wire.wire_codec(self.type_name, registry=node.registry).decode_view

    def _on_sample(self, payload: bytes) -> None:
        try:
            self._check(payload)
        except Exception as error:
            self.report_exception("decode", error)
            return
        self.publisher.publish(payload)
        self._forwarded(payload)

    def close(self) -> None:
        self.zenoh_subscriber.close()
        self.node.ros_node.destroy_publisher(self.publisher)
        _release_peer(self.node)
        super().close()


BRIDGE_CLASSES: dict[str, type[_BridgeAgent]] = {"sub": RosToZenohAgent, "pub": ZenohToRosAgent}


def make_bridge_agent(
    node: AgentHost,
    *,
    transport: str,
    conn_name: str,
    conn_type: str,
    agent_name: str | None,
    options: dict[str, Any],
) -> NodeAgent:
    """The bridge agent for ``add_agent(..., transport=...)``; bad kinds and options raise."""
    name = agent_name or conn_name
    if transport != "zenoh":
        raise PyconnectError(f"agent {name!r}: unknown transport {transport!r}; expected 'zenoh'")
    agent_class = BRIDGE_CLASSES.get(conn_type)
    if agent_class is None:
        raise PyconnectError(
            f"agent {name!r}: transport='zenoh' bridges conn_type 'sub' (ROS to zenoh) or "
            f"'pub' (zenoh to ROS), got {conn_type!r}"
        )
    allowed = {"data_interface", "qos"}
    unknown = sorted(set(options) - allowed)
    if unknown:
        raise PyconnectError(
            f"agent {name!r} ({conn_type} over zenoh): option {unknown[0]!r} does not apply to "
            "a bridged agent (it takes data_interface and qos)"
        )
    if "data_interface" not in options:
        raise PyconnectError(f"agent {name!r} ({conn_type} over zenoh): missing data_interface")
    return agent_class(node, conn_name=conn_name, agent_name=agent_name, **options)
