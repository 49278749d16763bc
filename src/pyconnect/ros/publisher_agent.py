"""``pub`` agents: ``send(value)`` encodes and publishes; ``time_period`` publishes on a timer.

What a periodic pub publishes each ``time_period``: ``response_func()``'s value when it has one
(an ``async def`` one is awaited on the coroutine loop; ``None`` skips that period); else the
last value ``send()`` was given; else, before any value was sent, the message ``encode_func``
makes from ``None`` (``encode_func(None, msg)``: the function fills the message itself, as the
design's minimal talker does). A pub with neither a value nor an ``encode_func`` publishes
nothing until its first ``send()``.

Outgoing headers: a message with a ``std_msgs/Header`` whose stamp is still zero gets the node
clock's time, and an empty ``frame_id`` gets the agent's ``frame_id`` option; a ``Stamped``
value (or a stamp the encode function set) is left as it is. ``only_if_subscribed=True``
skips the periodic ``response_func``, the encoding and the publishing while nobody listens.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

from typing import Any

from rclpy.callback_groups import CallbackGroup
from rclpy.qos import QoSProfile

from pyconnect.codecs.base import Codec
from pyconnect.codecs.stamped import Stamped
from pyconnect.errors import PyconnectError
from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.conversion import DecodeFunc, EncodeFunc
from pyconnect.ros.interfaces import interface_class
from pyconnect.ros.node_agent import NodeAgent, ResponseFunc
from pyconnect.ros.option_checks import period_problem
from pyconnect.ros.qos import resolve_qos
from pyconnect.ros.raw_path import RawEncoder, choose_raw
from pyconnect.ros.serialized_io import publish_serialized


class PublisherAgent(NodeAgent):
    """Publishes values of ``data_interface`` on ``conn_name``."""

    conn_type = "pub"

    def __init__(
        self,
        node: AgentHost,
        *,
        conn_name: str,
        agent_name: str | None = None,
        data_interface: object,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        codec: Codec | None = None,
        response_func: ResponseFunc | None = None,
        do_log_msg: bool = False,
        qos: QoSProfile | str | int | None = None,
        time_period: float | None = None,
        frame_id: str = "",
        only_if_subscribed: bool = False,
        raw: bool | None = None,
        callback_group: CallbackGroup | None = None,
    ) -> None:
        msg_class = interface_class(data_interface, kind="msg")
        super().__init__(
            node,
            conn_name=conn_name,
            agent_name=agent_name,
            data_interface=msg_class,
            response_func=response_func,
            do_log_msg=do_log_msg,
            callback_group=callback_group,
        )
        if response_func is not None and time_period is None:
            raise self.error("response_func on a 'pub' agent needs time_period (it is polled)")
        problem = None if time_period is None else period_problem(time_period)
        if problem is not None:
            raise self.error(problem)
        self.conversion = self.make_conversion(
            msg_class,
            encode_func=encode_func,
            decode_func=decode_func,
            codec=codec,
            eager=encode_func is None,
        )
        self.frame_id = frame_id
        self.only_if_subscribed = only_if_subscribed
        self.time_period = time_period
        self.sent_count = 0
        self._has_encode_func = encode_func is not None
        self._has_value = False
        self._message_values = (msg_class, Stamped)
        self._is_empty = self.conversion.is_empty
        # Only image-like types have an ``encoding`` that decides the log's channel order.
        self._has_encoding = "encoding" in msg_class.get_fields_and_field_types()
        self._raw: RawEncoder | None = None
        """Set when values are published as the CDR bytes the wire codec wrote (raw_path)."""
        custom = [
            name
            for name, given in (
                ("encode_func", encode_func is not None),
                ("codec", codec is not None),
            )
            if given
        ]
        if choose_raw(
            raw,
            describe=self.describe,
            custom=custom,
            value_codec=None if custom else node.registry.value_codec(self.type_name),
        ):
            encoder = RawEncoder(
                msg_type=self.type_name,
                registry=node.registry,
                has_header=self.conversion.has_header,
                describe=self.describe,
            )
            self._raw = encoder if encoder.usable else None
        ros_node = node.ros_node
        self.publisher = ros_node.create_publisher(
            msg_class,
            conn_name,
            resolve_qos(qos, msg_type=self.type_name, publisher=True),
            callback_group=self.callback_group,
        )
        try:
            self.topic = self.publisher.topic_name
            self.timer = (
                ros_node.create_timer(
                    time_period, self._on_period, callback_group=self.callback_group
                )
                if time_period is not None
                else None
            )
        except BaseException:
            # The agent is not added: a publisher left behind would stay on the graph, owned
            # by nothing, until the node ends.
            ros_node.destroy_publisher(self.publisher)
            raise

    @property
    def subscriber_count(self) -> int:
        """How many subscriptions match this publisher now."""
        count: int = self.publisher.get_subscription_count()
        return count

    def send(self, data: Any = None) -> bool:
        """Encode and publish ``data``; False when skipped (``only_if_subscribed``, no reader)."""
        try:
            return self._publish(data)
        except PyconnectError:
            raise
        except Exception as error:
            if not self.node.shutdown_event.is_set():
                raise
            # rclpy's own words ("cannot use Destroyable") name neither the agent nor the cause.
            raise PyconnectError(
                f"{self.describe}: node {self.node.qualified_name!r} is shut down"
            ) from error

    def _publish(self, data: Any) -> bool:
        if self.only_if_subscribed and self.publisher.get_subscription_count() == 0:
            return False
        raw = self._raw
        if raw is not None and not self._is_message_value(data):
            encode_bytes = raw.encode_bytes
            if encode_bytes is not None:  # a String, a number, a flat MultiArray
                publish_serialized(self.publisher, encode_bytes(data))
                self._sent(data)
                return True
            cdr, fields = raw.encode(data, now=self._now, frame_id=self.frame_id)
            publish_serialized(self.publisher, cdr)  # no copy before rcl's
            if self._has_encoding:
                encoding = fields.get("encoding")
                self._log_rgb = isinstance(encoding, str) and encoding.startswith("rgb")
            self._sent(data)
            return True
        conversion = self.conversion
        msg, stamped = conversion.encode(data)
        if conversion.has_header and not stamped:
            header = msg.header
            if header.stamp.sec == 0 and header.stamp.nanosec == 0:
                header.stamp = self.node.ros_node.get_clock().now().to_msg()
            if self.frame_id and not header.frame_id:
                header.frame_id = self.frame_id
        self.publisher.publish(msg)
        self._note_channel_order(msg)
        self._sent(data)
        return True

    def _sent(self, data: Any) -> None:
        self._latest = data
        self._has_value = data is not None
        self.sent_count += 1
        if self.do_log_msg:
            self.log_msg(data)

    def _is_message_value(self, data: Any) -> bool:
        """Values the class path publishes as messages (a message, Stamped, an empty type)."""
        return isinstance(data, self._message_values) or (data is None and self._is_empty)

    def _now(self) -> tuple[int, int]:
        sec, nanosec = self.node.ros_node.get_clock().now().seconds_nanoseconds()
        return int(sec), int(nanosec)

    def publish(self, data: Any = None) -> bool:
        """``send(data)`` by the design's name for publishers."""
        return self.send(data)

    async def send_async(self, data: Any = None) -> bool:
        """``send(data)`` for code on an asyncio loop (publishing never blocks)."""
        return self.send(data)

    def _on_period(self) -> None:
        if self.only_if_subscribed and self.publisher.get_subscription_count() == 0:
            return
        function = self.response_func
        if function is not None:
            if self.is_async(function):
                self.call_user("periodic send", function, on_done=self._send_period_value)
                return
            # The plain case inline (call_user's rule: whatever raises is reported).
            try:
                value = function()
                if value is not None:
                    self.send(value)
            except Exception as error:
                self.report_exception("periodic send", error)
            return
        try:
            if self._has_value:
                self.send(self._latest)
            elif self._has_encode_func:
                self.send(None)
        except Exception as error:
            self.report_exception("periodic send", error)

    def _send_period_value(self, value: Any) -> None:
        if value is not None:
            self.send(value)

    def close(self) -> None:
        if self.timer is not None:
            self.node.ros_node.destroy_timer(self.timer)
        self.node.ros_node.destroy_publisher(self.publisher)
        super().close()
