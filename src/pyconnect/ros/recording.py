"""``node.record(path)``: raw (CDR) subscriptions written to an MCAP file as they arrive.

Subscribed as ``pyconnect bag record`` subscribes (pyconnect.ros.recording_qos): one
subscription per topic, made once a publisher of it is discovered, with a QoS that matches its
publishers (reliable unless one is best effort; transient local when all are, so a latched
message sent earlier is recorded too) and a deep queue, re-made when a later publisher offers
less (pyconnect.ros.recording_subscription), and the publishers' QoS and RIHS01 type hash
stored as the topic's ``offered_qos_profiles`` and ``type_description_hash``. So the recording
holds what the node's agents receive, not what a best-effort keep-last-5 reader happens to
catch, nor what a reader chosen before the publishers were known could hear.

Messages DDS loses before they reach the recording's subscriptions (a fast 1080p camera) are
counted per topic from their ``message_lost`` events: the first loss of a topic is logged, with
the topic and the count so far, ``lost`` holds the counts, and ``stop()`` logs them once more.
A loss is no failure of the bag: nothing is raised for it.

A write that fails (a full disk) ends the writing, as it ends ``pyconnect bag record``: it is
logged once as the recording's ``error``, naming the bag; the messages received after it are
counted, not written; ``stop()`` raises one ``BagError`` naming the bag and counting the
received messages it does not hold, after closing the file and writing metadata.yaml if the disk
has room for it (pyconnect.record.mcap_recorder).
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from pyconnect.errors import PyconnectError
from pyconnect.record.bag_errors import BagError
from pyconnect.ros.interfaces import interface_class, interface_name
from pyconnect.ros.node_agent import NodeAgent
from pyconnect.ros.recording_qos import offered_qos_yaml, offered_type_hash
from pyconnect.ros.recording_subscription import RecordingSubscription, lost_text
from pyconnect.ros.subscriber_agent import SubscriberAgent

DISCOVERY_PERIOD = 0.1
"""Seconds between looks for the publishers of topics not subscribed yet."""


class Recording:
    """A running MCAP recording; ``stop()`` ends it and closes the file.

    ``error`` is the failure that ended the writing (None while it goes on).
    """

    def __init__(
        self,
        ros_node: Node,
        agents: Mapping[str, NodeAgent],
        path: Path,
        topics: list[str] | None,
    ) -> None:
        from pyconnect.record.mcap_recorder import McapRecorder

        self.ros_node = ros_node
        self.agents = agents
        self.path = path
        self._lock = threading.Lock()
        self._stopped = False
        # Callbacks write under it, so that stop() closes the file between two writes.
        self._write_lock = threading.Lock()
        self._received = 0
        self.error: OSError | None = None
        chosen = self._choose_topics(topics)
        self.recorder = McapRecorder(path)
        self._subscriptions: dict[str, RecordingSubscription] = {}
        self._group = MutuallyExclusiveCallbackGroup()
        self._waiting = dict(chosen)
        """Topics no publisher of which is known yet: subscribed once one is discovered."""
        self._discovery_timer: Any = None
        self._subscribe_discovered()
        self._discovery_timer = (
            # Wall time, not the node's clock: under use_sim_time with /clock absent or paused
            # a ROS-time timer never fires, and nothing would ever be recorded.
            ros_node.create_timer(
                DISCOVERY_PERIOD,
                self._subscribe_discovered,
                callback_group=self._group,
                clock=Clock(clock_type=ClockType.STEADY_TIME),
            )
            if self._waiting
            else None
        )
        self.topics = list(chosen)

    def _subscribe_discovered(self) -> None:
        """Subscribe to each waiting topic whose publishers are known, with their QoS.

        Before any publisher is known a reader's QoS would be a guess: a reliable one never
        hears a best-effort driver, a volatile one misses a latched message, and best effort
        loses frames of reliable publishers; so the subscription waits for the publishers.
        """
        with self._lock:
            if self._stopped:
                return
            for topic, (msg_class, source) in list(self._waiting.items()):
                publishers = self.ros_node.get_publishers_info_by_topic(source)
                if not publishers:
                    continue
                del self._waiting[topic]
                msg_type = interface_name(msg_class)
                self.recorder.add_topic(
                    topic,
                    msg_type,
                    offered_qos_profiles=offered_qos_yaml(publishers),
                    type_hash=offered_type_hash(publishers, msg_type),
                )
                self._subscriptions[topic] = RecordingSubscription(
                    self.ros_node,
                    msg_class=msg_class,
                    topic=source,
                    write=self._writer_for(topic),
                    callback_group=self._group,
                )
            timer = self._discovery_timer
            if not self._waiting and timer is not None:
                timer.cancel()

    def _choose_topics(self, topics: list[str] | None) -> dict[str, tuple[type, str]]:
        """{topic: (message class, the name to hand rclpy)}, each topic once: a second
        subscription to a topic (two sub agents on it, or a name given twice) would write every
        message twice.

        rclpy applies the node's remap rules to every name it is given, the graph queries'
        too, so a topic already resolved (an agent's ``topic``, a name from the graph) would be
        remapped twice (``-r left:=right -r right:=left`` would record /left as /right): rclpy
        gets the name the node's rules turn into the topic (``_source_name``).
        """
        chosen: dict[str, tuple[type, str]] = {}
        for topic, msg_class, source in self._named_topics(topics):
            known, _source = chosen.setdefault(topic, (msg_class, source))
            if interface_name(known) != interface_name(msg_class):
                raise PyconnectError(
                    f"record: topic {topic!r}: expected one type, got "
                    f"{interface_name(known)} and {interface_name(msg_class)}"
                )
        return chosen

    def _named_topics(self, topics: list[str] | None) -> list[tuple[str, type, str]]:
        """(topic, class, name for rclpy) of every sub agent, or of each of ``topics`` (an
        agent's name or topic, or a topic of the graph), repeats included."""
        known: dict[str, NodeAgent] = {}
        for agent in self.agents.values():
            topic = getattr(agent, "topic", None)
            if topic is not None and agent.data_interface is not None:
                known[topic] = agent
        for agent in self.agents.values():
            if getattr(agent, "topic", None) is not None and agent.data_interface is not None:
                known[agent.name] = agent  # a name wins over a topic spelt the same
        if topics is None:
            return [
                (agent.topic, agent.data_interface, agent.conn_name)  # type: ignore[misc]
                for agent in self.agents.values()
                if isinstance(agent, SubscriberAgent)
            ]
        graph = dict(self.ros_node.get_topic_names_and_types())
        chosen: list[tuple[str, type, str]] = []
        for topic in topics:
            if topic in known:
                agent = known[topic]
                chosen.append((agent.topic, agent.data_interface, agent.conn_name))  # type: ignore[attr-defined,arg-type]
            elif graph.get(topic):
                msg_class = interface_class(graph[topic][0], kind="msg")
                chosen.append((topic, msg_class, self._source_name(topic, graph)))
            else:
                raise PyconnectError(
                    f"record: topic {topic!r} has no agent and is not in the graph"
                )
        return chosen

    def _source_name(self, topic: str, graph: Mapping[str, object]) -> str:
        """A name the node's remap rules turn into ``topic`` (itself when no rule touches it)."""
        resolve = self.ros_node.resolve_topic_name
        candidates = [topic, *(agent.conn_name for agent in self.agents.values()), *graph]
        for name in candidates:
            try:
                if resolve(name) == topic:
                    return name
            except Exception:  # a name rclpy cannot resolve maps to nothing
                continue
        raise PyconnectError(
            f"record: topic {topic!r} is remapped by this node's --ros-args rules to "
            f"{resolve(topic)!r}, and no name known here maps to it"
        )

    def _writer_for(self, topic: str) -> Callable[[bytes], None]:
        recorder = self.recorder

        def write(cdr: bytes) -> None:
            with self._write_lock:
                if self._stopped:
                    return
                self._received += 1
                if self.error is not None:
                    return  # counted as lost: stop() tells how many
                try:
                    recorder.write(topic, cdr, log_time_ns=time.time_ns())
                except OSError as error:
                    # Raised, it was a traceback per message for as long as the disk was full.
                    self.error = error
                    self.ros_node.get_logger().error(
                        f"record: {self.path}: writing the bag failed ({error}); the messages "
                        "received from now on are not written (stop() counts them)"
                    )

        return write

    @property
    def messages_written(self) -> int:
        """Messages in the bag (once ``stop()`` read back a file that failed: found in it)."""
        count: int = self.recorder.messages_written
        return count

    @property
    def messages_received(self) -> int:
        """Messages the subscriptions received, those not written after a failure included."""
        return self._received

    @property
    def lost(self) -> dict[str, int]:
        """{topic: messages DDS lost before they reached the recording}, the topics that lost
        any (their subscriptions' ``message_lost`` events)."""
        with self._lock:
            subscriptions = list(self._subscriptions.items())
        return {topic: sub.lost_count for topic, sub in subscriptions if sub.lost_count}

    @property
    def stopped(self) -> bool:
        """True once ``stop()`` was called."""
        return self._stopped

    def stop(self) -> None:
        """Stop recording and close the file (idempotent).

        Raises ``BagError`` (once) when writing failed or the file could not be finished: it
        names the bag and counts the received messages it does not hold.
        """
        with self._lock:
            if self._stopped:
                return
            self._stopped = True
        if self._discovery_timer is not None:
            with contextlib.suppress(Exception):
                self.ros_node.destroy_timer(self._discovery_timer)
        for subscription in self._subscriptions.values():
            subscription.close()
        if dropped := self.lost:  # the first loss was logged with the count then: here the last
            self.ros_node.get_logger().warning(
                f"record: {self.path}: DDS lost {lost_text(dropped)} before they reached the "
                "recording; they are not in the bag"
            )
        finishing: Exception | None = None
        with self._write_lock:  # a callback still writing ends first; later ones write nothing
            try:
                self.recorder.close()
            except Exception as error:  # Ctrl-C is no failure of the bag
                finishing = error
        failure = self.error or finishing
        if failure is None:
            return
        # The file that failed was read back when closed: its count is what the bag holds.
        lost = self._received - self.messages_written
        also = ""
        if finishing is not None and finishing is not failure:  # still full: told, not instead
            also = f"; finishing it failed too ({finishing})"
        raise BagError(
            f"{self.path}: writing the bag failed ({failure}); "
            f"{lost} received message(s) not written{also}"
        ) from failure
