"""``node.record(path)``: raw (CDR) subscriptions written to an MCAP file as they arrive.

Subscribed as ``pyconnect bag record`` subscribes (pyconnect.ros.recording_qos): one
subscription per topic, made once a publisher of it is discovered, with a QoS that matches its
publishers (reliable unless one is best effort; transient local when all are, so a latched
message sent earlier is recorded too) and a deep queue, and the publishers' QoS stored as the
topic's ``offered_qos_profiles``. So the recording holds what the node's agents receive, not
what a best-effort keep-last-5 reader happens to catch, nor what a reader chosen before the
publishers were known could hear.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node

from pyconnect.errors import PyconnectError
from pyconnect.ros.interfaces import interface_class, interface_name
from pyconnect.ros.node_agent import NodeAgent
from pyconnect.ros.recording_qos import offered_qos_yaml, recording_qos
from pyconnect.ros.subscriber_agent import SubscriberAgent

DISCOVERY_PERIOD = 0.1
"""Seconds between looks for the publishers of topics not subscribed yet."""


class Recording:
    """A running MCAP recording; ``stop()`` ends it and closes the file."""

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
        chosen = self._choose_topics(topics)
        self.recorder = McapRecorder(path)
        self._subscriptions: list[Any] = []
        self._group = MutuallyExclusiveCallbackGroup()
        self._waiting = dict(chosen)
        """Topics no publisher of which is known yet: subscribed once one is discovered."""
        self._discovery_timer: Any = None
        self._subscribe_discovered()
        self._discovery_timer = (
            ros_node.create_timer(
                DISCOVERY_PERIOD, self._subscribe_discovered, callback_group=self._group
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
            for topic, msg_class in list(self._waiting.items()):
                publishers = self.ros_node.get_publishers_info_by_topic(topic)
                if not publishers:
                    continue
                del self._waiting[topic]
                self.recorder.add_topic(
                    topic,
                    interface_name(msg_class),
                    offered_qos_profiles=offered_qos_yaml(publishers),
                )
                self._subscriptions.append(
                    self.ros_node.create_subscription(
                        msg_class,
                        topic,
                        self._writer_for(topic),
                        recording_qos(publishers),
                        callback_group=self._group,
                        raw=True,
                    )
                )
            timer = self._discovery_timer
            if not self._waiting and timer is not None:
                timer.cancel()

    def _choose_topics(self, topics: list[str] | None) -> dict[str, type]:
        """{topic: message class}, each topic once: a second subscription to a topic (two sub
        agents on it, or a name given twice) would write every message twice."""
        chosen: dict[str, type] = {}
        for topic, msg_class in self._named_topics(topics):
            known = chosen.setdefault(topic, msg_class)
            if interface_name(known) != interface_name(msg_class):
                raise PyconnectError(
                    f"record: topic {topic!r}: expected one type, got "
                    f"{interface_name(known)} and {interface_name(msg_class)}"
                )
        return chosen

    def _named_topics(self, topics: list[str] | None) -> list[tuple[str, type]]:
        """(topic, class) of every sub agent, or of each of ``topics`` (an agent's name or a
        topic), repeats included."""
        known: dict[str, type] = {}
        for agent in self.agents.values():
            topic = getattr(agent, "topic", None)
            if topic is not None and agent.data_interface is not None:
                known[topic] = agent.data_interface  # type: ignore[assignment]
                known[agent.name] = agent.data_interface  # type: ignore[assignment]
        if topics is None:
            return [
                (agent.topic, agent.data_interface)  # type: ignore[misc]
                for agent in self.agents.values()
                if isinstance(agent, SubscriberAgent)
            ]
        graph = dict(self.ros_node.get_topic_names_and_types())
        chosen: list[tuple[str, type]] = []
        for topic in topics:
            if topic in known:
                resolved = next(
                    (
                        getattr(agent, "topic", topic)
                        for agent in self.agents.values()
                        if agent.name == topic
                    ),
                    topic,
                )
                chosen.append((resolved, known[topic]))
            elif graph.get(topic):
                chosen.append((topic, interface_class(graph[topic][0], kind="msg")))
            else:
                raise PyconnectError(
                    f"record: topic {topic!r} has no agent and is not in the graph"
                )
        return chosen

    def _writer_for(self, topic: str) -> Any:
        recorder = self.recorder

        def write(cdr: bytes) -> None:
            if not self._stopped:
                recorder.write(topic, cdr, log_time_ns=time.time_ns())

        return write

    @property
    def messages_written(self) -> int:
        count: int = self.recorder.messages_written
        return count

    def stop(self) -> None:
        """Stop recording and close the file (idempotent)."""
        with self._lock:
            if self._stopped:
                return
            self._stopped = True
        if self._discovery_timer is not None:
            with contextlib.suppress(Exception):
                self.ros_node.destroy_timer(self._discovery_timer)
        for subscription in self._subscriptions:
            # The node may be destroyed already.
            with contextlib.suppress(Exception):
                self.ros_node.destroy_subscription(subscription)
        self.recorder.close()
