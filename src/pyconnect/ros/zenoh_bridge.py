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

Loops: a topic bridged both ways (by one node, or by two processes) would otherwise go round
for ever: ROS -> zenoh -> ROS -> zenoh ... So the zenoh -> ROS side never republishes a sample a
bridge put on zenoh: such a sample came from the ROS graph of that domain, where it already
is. A bridge's zenoh publishers are recognised by their GID (the one in every sample's
attachment): each ``'sub'`` bridge declares a liveliness token ``@pyconnect_bridge/<domain>/<GID
hex>`` (its own process knows it at once), and every bridge peer keeps the set of live ones.
The ROS -> zenoh side cannot tell a bridge's ROS publisher from any other (rclpy Jazzy's message
info names no publisher GID), so a node that bridges a topic both ways keeps a short record of
what its zenoh -> ROS side just published there (pyconnect.ros.bridge_echo) and its ROS ->
zenoh side skips each of those once when it comes back from ROS: a zenoh peer's message reaches
zenoh subscribers once. Bridges of one topic in two processes, one each way, cannot share that
record: a peer's message then reaches zenoh twice (once from the peer, once from the other
bridge), never more. This assumes the bridges of one domain share one ROS graph.

QoS: ``qos=`` (or the default for the type) sets the ROS side, and its depth the zenoh side
(the keep-last depth of the zenoh subscription, the depth the tokens advertise). A sensor
type without ``qos=`` is subscribed on ROS as a ``'sub'`` agent does
(pyconnect.ros.sensor_subscription): reliable unless a publisher is best effort.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import contextlib
import struct
import threading
import time
import weakref
from typing import Any

import zenoh
from rclpy.qos import HistoryPolicy, QoSProfile

from pyconnect.codecs import wire
from pyconnect.errors import PyconnectError
from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.bridge_echo import RecentlyPublished, qos_compatible
from pyconnect.ros.interfaces import interface_class
from pyconnect.ros.node_agent import NodeAgent
from pyconnect.ros.qos import follows_publishers, resolve_qos
from pyconnect.ros.sensor_subscription import SensorSubscription
from pyconnect.transport import rmw_zenoh_keys as keys
from pyconnect.transport.peer import Peer
from pyconnect.transport.peer_agent import DEFAULT_DEPTH
from pyconnect.transport.peer_options import KEEP_ALL_DEPTH
from pyconnect.transport.topic_publisher import PublisherAgent
from pyconnect.transport.topic_subscriber import SubscriberAgent

BRIDGE_SPACE = "@pyconnect_bridge"
"""Liveliness tokens ``@pyconnect_bridge/<domain>/<GID hex>`` name the zenoh publishers of
bridges (outside rmw_zenoh's ``@ros2_lv``, so ROS graphs never see them)."""


def zenoh_depth(profile: QoSProfile) -> int:
    """The zenoh-side depth of a bridge whose ROS side uses ``profile``."""
    depth = int(profile.depth)
    if profile.history == HistoryPolicy.KEEP_ALL:
        return max(depth, KEEP_ALL_DEPTH)
    return depth if depth >= 1 else DEFAULT_DEPTH


class BridgeSession:
    """One node's bridge ``Peer`` and the GIDs of every bridge's zenoh publishers it sees."""

    def __init__(self, node: AgentHost) -> None:
        self.peer = Peer(
            node.name,
            namespace=node.ros_node.get_namespace(),
            registry=node.registry,
            handle_signals=False,
        )
        self.bridge_gids: set[bytes] = set()
        """GIDs of bridges' zenoh publishers, here and in other processes (set operations are
        atomic under the GIL: zenoh's thread adds, agents' threads read)."""
        self.recently_published = RecentlyPublished()
        """What this node's zenoh -> ROS agents just published, for its ROS -> zenoh ones."""
        self._prefix = f"{BRIDGE_SPACE}/{self.peer.domain_id}/"
        self._tokens: dict[bytes, Any] = {}
        liveliness = self.peer.session.liveliness()
        self._subscriber: Any = liveliness.declare_subscriber(
            f"{self._prefix}*", self._on_token, history=True
        )

    def _on_token(self, sample: zenoh.Sample) -> None:
        try:
            gid = bytes.fromhex(str(sample.key_expr).rsplit("/", 1)[1])
        except ValueError:
            return  # not a GID: nothing of ours
        if sample.kind == zenoh.SampleKind.DELETE:
            if gid not in self._tokens:  # ours stay until our publisher closes
                self.bridge_gids.discard(gid)
        else:
            self.bridge_gids.add(gid)

    def declare_bridge_publisher(self, gid: bytes) -> None:
        """Mark ``gid`` as a bridge's zenoh publisher, here at once and for other peers."""
        self.bridge_gids.add(gid)
        liveliness = self.peer.session.liveliness()
        self._tokens[gid] = liveliness.declare_token(self._prefix + gid.hex())

    def undeclare_bridge_publisher(self, gid: bytes) -> None:
        token = self._tokens.pop(gid, None)
        self.bridge_gids.discard(gid)
        if token is not None:
            with contextlib.suppress(Exception):
                token.undeclare()

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._subscriber.undeclare()
        self.peer.shutdown()


_peers_lock = threading.Lock()
_peers: weakref.WeakKeyDictionary[Any, tuple[BridgeSession, int]] = weakref.WeakKeyDictionary()


def _acquire_peer(node: AgentHost) -> BridgeSession:
    with _peers_lock:
        found = _peers.get(node)
        if found is None:
            found = (BridgeSession(node), 0)
        _peers[node] = (found[0], found[1] + 1)
        return found[0]


def _release_peer(node: AgentHost) -> None:
    with _peers_lock:
        found = _peers.get(node)
        if found is None:
            return
        shared, users = found
        if users > 1:
            _peers[node] = (shared, users - 1)
            return
        del _peers[node]
    shared.close()


class _PeersSubscriber(SubscriberAgent):
    """A zenoh subscription that skips what bridges published: it came from ROS already."""

    def __init__(self, peer: Peer, *, bridge_gids: set[bytes], **options: Any) -> None:
        self._bridge_gids = bridge_gids  # before the agent's thread starts
        self.bridged_skipped_count = 0
        """Samples skipped because a bridge put them on zenoh (they came from ROS)."""
        super().__init__(peer, **options)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        attachment = sample.attachment
        if attachment is not None:
            try:
                gid = keys.ATTACHMENT.unpack(attachment.to_bytes())[3]
            except struct.error:
                gid = b""
            if gid in self._bridge_gids:
                self.bridged_skipped_count += 1
                return
        super()._on_sample(sample)


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
        self.sensor_subscription: SensorSubscription | None = None
        """Set when the QoS follows the publishers (a sensor type without ``qos=``), as a
        ``'sub'`` agent's does: a best-effort reader would lose large frames of reliable ones."""
        if follows_publishers(qos, msg_type=self.type_name):
            self.sensor_subscription = SensorSubscription(
                node.ros_node,
                msg_class=msg_class,
                topic=conn_name,
                callback=self._on_message,
                raw=True,
                callback_group=self.callback_group,
                describe=self.describe,
            )
        else:
            self._subscription = node.ros_node.create_subscription(
                msg_class,
                conn_name,
                self._on_message,
                resolve_qos(qos, msg_type=self.type_name, publisher=False),
                callback_group=self.callback_group,
                raw=True,
            )
        self.topic = self.subscription.topic_name
        self.echo_skipped_count = 0
        """Messages skipped because this node's zenoh -> ROS agent of the topic published them
        (they came from zenoh)."""
        self._session = _acquire_peer(node)
        self._recent = self._session.recently_published
        self._recent.watch(self.topic, self._hears)
        self.peer = self._session.peer
        self.zenoh_publisher = PublisherAgent(
            self.peer,
            conn_name=self.topic,
            data_interface=self.type_name,
            raw=True,
            depth=zenoh_depth(self.subscription.qos_profile),
        )
        self._session.declare_bridge_publisher(self.zenoh_publisher.gid)

    @property
    def subscription(self) -> Any:
        """The rclpy subscription now receiving (a sensor one is replaced when it switches)."""
        if self.sensor_subscription is not None:
            return self.sensor_subscription.subscription
        return self._subscription

    def _hears(self, publisher_qos: QoSProfile) -> bool:
        """Whether this agent's reader (as it is now) hears a publisher of ``publisher_qos``."""
        return qos_compatible(publisher_qos, self.subscription.qos_profile)

    def _on_message(self, payload: bytes) -> None:
        if self._recent.came_back(self.topic, payload):
            self.echo_skipped_count += 1
            return
        try:
            self.zenoh_publisher.send(payload)
        except Exception as error:
            self.report_exception("zenoh publish", error)
            return
        self._forwarded(payload)

    def close(self) -> None:
        if self.sensor_subscription is not None:
            self.sensor_subscription.close()
        else:
            self.node.ros_node.destroy_subscription(self._subscription)
        self.zenoh_publisher.close()
        self._session.undeclare_bridge_publisher(self.zenoh_publisher.gid)
        self._recent.unwatch(self.topic, self._hears)
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
        profile = resolve_qos(qos, msg_type=self.type_name, publisher=True)
        self.publisher = node.ros_node.create_publisher(
            msg_class, conn_name, profile, callback_group=self.callback_group
        )
        self.topic = self.publisher.topic_name
        self._session = _acquire_peer(node)
        self._recent = self._session.recently_published
        self.peer = self._session.peer
        self.zenoh_subscriber: SubscriberAgent = _PeersSubscriber(
            self.peer,
            bridge_gids=self._session.bridge_gids,
            conn_name=self.topic,
            data_interface=self.type_name,
            raw=True,
            response_func=self._on_sample,
            depth=zenoh_depth(profile),
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
        self._recent.published(self.topic, payload, self.publisher.qos_profile)
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
