"""The raw CDR path of ``sub`` and ``pub`` agents: serialized bytes <-> values by the wire codecs.

By default (``raw=None``) and with ``raw=True``, a subscription receives the serialized message
(rclpy's ``raw=True``) and the wire codec decodes it (the natural codec reads a writable view:
of a copy for small messages, of the taken bytes themselves for large ones, see
``writable_buffer``; or the lossless dict is built straight from them); a publisher
publishes the bytes the wire codec wrote (String, the numbers and flat MultiArrays through the
straight-line encoders of ``codecs/fast_paths.py``). Both skip rclpy's conversion between C
structs and Python message objects, which is most of the cost of a large message (a 6 MB
image: 9.6 ms stock in rclpy against microseconds here).

The values are the class path's: the same registry codec turns the view or the fields into the
value (``tests/ros/test_raw_path.py`` compares both paths for every natural codec). Outgoing
headers are filled as the class path fills them: a zero stamp gets the node clock's time, an
empty ``frame_id`` the agent's ``frame_id``. What needs an rclpy message stays on the class
path: ``encode_func``/``decode_func``, a ``codec=`` of the agent's own, ``stamped=True``
subscribers, natural codecs without ``to_fields``, and (unless ``raw=True``) codecs the user
registered; values that already are messages or ``Stamped`` are published from the message.
``raw=False`` keeps an agent on the class path. bench/agents.py measured the raw path cheaper
for small messages too (README), hence the default.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.buffers import writable_bytes
from pyconnect.codecs.fast_paths import fast_decoder, fast_encoder
from pyconnect.codecs.point_cloud import point_cloud_layout
from pyconnect.codecs.point_cloud_cdr import CLOUD, cloud_cdr, writes_in_one_pass
from pyconnect.codecs.registry import Registry
from pyconnect.codecs.wire_codec import WireCodec
from pyconnect.errors import CodecError, EncodeError, PyconnectError

BUILT_IN_MODULES = ("pyconnect.codecs", "pyconnect_generated")
"""Where pyconnect's own codecs live; a codec from elsewhere was registered by the user."""


def choose_raw(raw: bool | None, *, describe: str, custom: list[str], value_codec: Any) -> bool:
    """Whether an agent takes the raw path: ``raw=None`` (the default) does when nothing needs
    an rclpy message; ``raw=True`` insists, and is refused beside what needs a message."""
    if raw is False:
        return False
    if custom:
        if raw:
            raise PyconnectError(
                f"{describe}: raw=True converts with the wire codecs; it cannot be combined "
                f"with {', '.join(custom)} (they work on rclpy messages)"
            )
        return False
    if raw is None and value_codec is not None:
        # A codec the user registered may read more of a message than its fields.
        return str(type(value_codec).__module__).startswith(BUILT_IN_MODULES)
    return True


class RawDecoder:
    """Serialized bytes -> the value a ``sub`` agent delivers."""

    def __init__(self, *, msg_type: str, registry: Registry) -> None:
        self.wire: WireCodec = registry.wire_codec(msg_type)
        self.natural = registry.value_codec(msg_type)
        self.decode_value: Callable[[bytes], Any] | None = fast_decoder(
            self.natural, self._general_value
        )
        """The straight-line decoder of a String, a number or a flat ``*MultiArray``
        (codecs/fast_paths.py) or None; what it cannot prove well formed goes to ``decode``,
        which raises as usual."""

    def _general_value(self, data: bytes) -> Any:
        return self.decode(data)[0]

    def decode(self, data: bytes) -> tuple[Any, Any]:
        """(value, the view the natural codec read or None for a dict type)."""
        natural = self.natural
        if natural is None:
            return self.wire.to_dict(data), None
        view = self.wire.decode_view(writable_buffer(data))
        return natural.decode(view), view


IN_PLACE_BYTES = 64 * 1024
"""From this size a taken message is made writable in place rather than copied."""


def writable_buffer(data: bytes | bytearray | memoryview) -> bytearray | npt.NDArray[np.uint8]:
    """A writable buffer with the bytes of a message rclpy just took.

    The values handed out are writable, as the class path's arrays (rclpy's ``array('B')``).
    A small message is copied into a ``bytearray``. A large one (``IN_PLACE_BYTES`` and up) is
    made writable where it is: rclpy created that ``bytes`` for this one message and nothing
    else holds or hashes it, so writing into it is what the C code that made it did; the copy
    it saves is 0.4-0.7 ms for a 1080p image (a third of the take stage). Sizes below 2 bytes,
    which CPython shares, never get here.
    """
    if type(data) is not bytes or len(data) < IN_PLACE_BYTES:
        return bytearray(data)
    return writable_bytes(data)


class RawEncoder:
    """A value -> serialized bytes a ``pub`` agent publishes (header filled as the class path)."""

    def __init__(
        self, *, msg_type: str, registry: Registry, has_header: bool, describe: str
    ) -> None:
        self.wire: WireCodec = registry.wire_codec(msg_type)
        self.natural = registry.value_codec(msg_type)
        self.has_header = has_header
        self.describe = describe
        self._is_cloud = msg_type == CLOUD
        fields_codec = registry.fields_codec(msg_type)
        self._fields_codec = fields_codec
        self._to_fields: Callable[[Any], Any] | None = (
            fields_codec.to_fields if fields_codec is not None else None
        )
        self.encode_bytes: Callable[[Any], bytes] | None = (
            None if has_header else fast_encoder(self.natural, self._general_bytes)
        )
        """The straight-line encoder of a small header-less type (codecs/fast_paths.py) or
        None; what it cannot prove well formed goes to ``encode``, which raises as usual."""

    @property
    def usable(self) -> bool:
        """False when the natural codec cannot give fields (the class path is taken)."""
        return self.natural is None or self._to_fields is not None

    def fields(self, value: Any) -> Mapping[str, Any]:
        """The lossless dict of ``value`` (through the natural codec's ``to_fields``)."""
        fields = self._to_fields(value) if self._to_fields is not None else value
        if fields.__class__ is not dict and not isinstance(fields, Mapping):
            raise EncodeError(
                f"{self.describe}: {self.wire.msg_type.rsplit('/', 1)[-1]}: "
                f"expected dict, got {type(fields).__name__}"
            )
        return fields

    def encode(
        self, value: Any, *, now: Callable[[], tuple[int, int]], frame_id: str
    ) -> tuple[bytes, Mapping[str, Any]]:
        """(CDR bytes, the fields written); errors become ``EncodeError`` naming the agent."""
        try:
            if self._is_cloud and writes_in_one_pass(self._fields_codec, value):
                return self._cloud(value, now=now, frame_id=frame_id)
            fields = self.fields(value)
            if self.has_header:
                fields = _with_header(fields, now=now, frame_id=frame_id)
            return self.wire.from_dict(fields), fields
        except CodecError as error:
            if str(error).startswith(self.describe):
                raise
            raise EncodeError(f"{self.describe}: {error}") from error
        except PyconnectError:
            raise
        except Exception as error:
            raise EncodeError(
                f"{self.describe}: codec raised {type(error).__name__}: {error}"
            ) from error

    def _general_bytes(self, value: Any) -> bytes:
        return self.encode(value, now=_no_header, frame_id="")[0]

    def _cloud(
        self, value: Any, *, now: Callable[[], tuple[int, int]], frame_id: str
    ) -> tuple[bytes, Mapping[str, Any]]:
        layout, points = point_cloud_layout(value)
        fields = _with_header(layout, now=now, frame_id=frame_id) if self.has_header else layout
        cdr = cloud_cdr(self.wire, fields, points)
        fields["data"] = points.reshape(-1).view(np.uint8).data
        return cdr, fields


def _no_header() -> tuple[int, int]:
    raise AssertionError("a type without a header needs no stamp")  # pragma: no cover


def _with_header(
    fields: Mapping[str, Any], *, now: Callable[[], tuple[int, int]], frame_id: str
) -> dict[str, Any]:
    header = fields.get("header")
    header = dict(header) if isinstance(header, Mapping) else {}
    stamp = header.get("stamp")
    stamp = dict(stamp) if isinstance(stamp, Mapping) else {}
    if not stamp.get("sec") and not stamp.get("nanosec"):
        sec, nanosec = now()
        stamp = {"sec": sec, "nanosec": nanosec}
    header["stamp"] = stamp
    if frame_id and not header.get("frame_id"):
        header["frame_id"] = frame_id
    return {**fields, "header": header}
