"""``sub`` agents: every message is decoded, kept for ``get()`` and passed to ``response_func``.

The callback is the hot path of the package (thousands of messages per second): it decodes,
stores, counts and calls the user function, nothing else. A message the codec rejects, or a
``response_func`` that raises, is reported (agent name and traceback) and the next one is
handled; ``get()`` keeps the last good value. An ``async def`` ``response_func`` runs on the
node's coroutine loop, one message after another (pyconnect.ros.coroutines).

Messages DDS loses before they reach the subscription (a best-effort camera's frames, a queue
a fast publisher overran) are counted in ``lost_count`` from the subscription's
``message_lost`` events, off the hot path, and the first loss is logged once per agent.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from rclpy.callback_groups import CallbackGroup
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.qos import QoSProfile

from pyconnect.codecs.base import Codec
from pyconnect.codecs.stamped import header_of
from pyconnect.errors import DecodeError
from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.agent_options import OptionError
from pyconnect.ros.conversion import DecodeFunc, EncodeFunc
from pyconnect.ros.coroutines import is_async_callable
from pyconnect.ros.following_subscription import create_counting_losses
from pyconnect.ros.interfaces import interface_class
from pyconnect.ros.node_agent import NodeAgent, ResponseFunc
from pyconnect.ros.option_checks import call_timeout
from pyconnect.ros.qos import follows_publishers, resolve_qos
from pyconnect.ros.raw_path import RawDecoder, choose_raw
from pyconnect.ros.sensor_subscription import SensorSubscription


class SubscriberAgent(NodeAgent):
    """Subscribes to ``conn_name`` and decodes each message to its natural value.

    ``stamped=True`` delivers ``codecs.Stamped(value, stamp_ns, frame_id)`` for types with a
    header.
    """

    conn_type = "sub"

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
        stamped: bool = False,
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
        # decode_stamped's own rule on an empty message: a type it finds no header in dropped
        # every message with a DecodeError.
        if stamped and header_of(msg_class()) is None:
            raise OptionError(
                f"{self.describe}: stamped=True needs a type with a std_msgs/Header, "
                f"and {self.type_name} has none"
            )
        own_codec = codec is not None
        self.conversion = self.make_conversion(
            msg_class, encode_func=encode_func, decode_func=decode_func, codec=codec
        )
        if decode_func is None:
            codec = self.conversion.codec
            if stamped:
                from pyconnect.codecs.stamped import decode_stamped

                self._decode = lambda msg: decode_stamped(codec, msg)
            else:
                self._decode = codec.decode
        else:
            self._decode = decode_func
        self._response_is_async = is_async_callable(response_func)
        # Only image-like types have an ``encoding`` that decides the log's channel order: the
        # message's, or the one a converting codec (ImageCodec(encoding=...)) decodes to.
        self._has_encoding = "encoding" in msg_class.get_fields_and_field_types()
        decoded_encoding = getattr(codec, "encoding", None) if decode_func is None else None
        self._decoded_rgb: bool | None = (
            decoded_encoding.startswith("rgb") if isinstance(decoded_encoding, str) else None
        )
        self._raw: RawDecoder | None = None
        """Set when messages arrive as CDR bytes and the wire codec decodes them (raw_path)."""
        custom = [
            name
            for name, given in (
                ("decode_func", decode_func is not None),
                ("codec", own_codec),
                ("stamped=True", stamped),
            )
            if given
        ]
        if choose_raw(
            raw,
            describe=self.describe,
            custom=custom,
            value_codec=None if custom else node.registry.value_codec(self.type_name),
        ):
            self._raw = RawDecoder(msg_type=self.type_name, registry=node.registry)
        self.message_count = 0
        self.last_received_ns = 0
        self._first_message = threading.Event()
        callback = self._on_message if self._raw is None else self._raw_callback(self._raw)
        self.sensor_subscription: SensorSubscription | None = None
        """Set when the QoS follows the publishers (a sensor type without ``qos=``)."""
        if follows_publishers(qos, msg_type=self.type_name):
            self.sensor_subscription = SensorSubscription(
                node.ros_node,
                msg_class=msg_class,
                topic=conn_name,
                callback=callback,
                raw=self._raw is not None,
                callback_group=self.callback_group,
                describe=self.describe,
            )
            self.topic: str = self.sensor_subscription.topic
        else:
            self._lost_lock = threading.Lock()
            self._lost = 0
            self._subscription = create_counting_losses(
                node.ros_node,
                msg_class,
                conn_name,
                callback,
                resolve_qos(qos, msg_type=self.type_name, publisher=False),
                callback_group=self.callback_group,
                event_callbacks=SubscriptionEventCallbacks(message_lost=self._on_message_lost),
                raw=self._raw is not None,
            )
            self.topic = self._subscription.topic_name

    @property
    def subscription(self) -> Any:
        """The rclpy subscription now receiving (a sensor one is replaced when it switches)."""
        if self.sensor_subscription is not None:
            return self.sensor_subscription.subscription
        return self._subscription

    @property
    def lost_count(self) -> int:
        """Messages DDS reported lost before they reached the subscription."""
        if self.sensor_subscription is not None:
            return self.sensor_subscription.lost_count
        return self._lost

    def _on_message_lost(self, status: Any) -> None:
        change = int(status.total_count_change)
        with self._lost_lock:  # a reentrant group may run two events at once
            first = self._lost == 0 and change > 0
            self._lost += change
            lost = self._lost
        if first:  # once: what loses one message loses many, the count goes on in lost_count
            self.node.get_logger().warning(
                f"{self.describe}: DDS lost {lost} message(s) on {self.topic} so far before "
                "they reached the subscription (the agent's lost_count counts on)"
            )

    def _raw_callback(self, raw: RawDecoder) -> Callable[[bytes], None]:
        """The subscription callback of the raw path: CDR bytes in, the same delivery."""

        decode_value = raw.decode_value  # String, numbers, flat arrays: read straight, no view

        def on_raw_message(data: bytes) -> None:
            try:
                if decode_value is not None:
                    value, view = decode_value(data), None
                else:
                    value, view = raw.decode(data)
            except Exception as error:
                self._decode_failed(error)
                return
            self._deliver(value, view)

        return on_raw_message

    def _on_message(self, msg: Any) -> None:
        try:
            value = self._decode(msg)
        except Exception as error:
            self._decode_failed(error)
            return
        self._deliver(value, msg)

    def _decode_failed(self, error: Exception) -> None:
        if not isinstance(error, DecodeError):
            error = DecodeError(f"{type(error).__name__}: {error}")
        self.report_exception("decode", error)

    def _deliver(self, value: Any, msg: Any) -> None:
        self._latest = value
        if self._has_encoding:
            if self._decoded_rgb is None:
                self._note_channel_order(msg)
            else:
                self._log_rgb = self._decoded_rgb
        self.message_count += 1
        self.last_received_ns = time.time_ns()
        if not self._first_message.is_set():
            self._first_message.set()
        if self.do_log_msg:
            self.log_msg(value)  # never raises: a log that cannot be opened is reported there
        if self.response_func is not None:
            if self._response_is_async:
                self.lane.submit(
                    self.response_func, (value,), on_done=None, on_error=self._response_failed
                )
                return
            try:
                self.response_func(value)
            except Exception as error:
                self.report_exception("response_func", error)

    def _response_failed(self, error: BaseException) -> None:
        self.report_exception("response_func", error)

    def wait_for_message(self, timeout: float | None = None) -> bool:
        """Wait until the first message arrived; False on timeout."""
        wait = call_timeout(timeout, None, where=f"{self.describe}: wait_for_message")
        return self._first_message.wait(wait)

    def is_connected(self) -> bool:
        return self.message_count > 0

    def info_text(self) -> str:
        age = (
            f", {(time.time_ns() - self.last_received_ns) / 1e9:.3f} s ago"
            if self.last_received_ns
            else ""
        )
        lost = f", {self.lost_count} lost on the way" if self.lost_count else ""
        return f"{super().info_text()} ({self.message_count} messages on {self.topic}{lost}{age})"

    def close(self) -> None:
        if self.sensor_subscription is not None:
            self.sensor_subscription.close()
        else:
            self.node.ros_node.destroy_subscription(self._subscription)
        super().close()
