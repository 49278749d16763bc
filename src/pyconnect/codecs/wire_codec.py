"""The CDR codec of one message type: natural values, lossless dicts and views <-> CDR bytes.

A ``WireCodec`` wraps the generated functions of its type (``type_code.WireCode``) and asks the
registry that made it for the type's user or natural codec.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Protocol

from pyconnect.codecs.base import Codec, DictCodec, NaturalCodec
from pyconnect.codecs.cdr_read import DecodeFunction, body_of
from pyconnect.codecs.cdr_write import HEADER_BE, HEADER_LE, ZEROS
from pyconnect.codecs.fastdds_size import fastdds_estimated_size
from pyconnect.codecs.field_path import FieldError, WireDecodeError
from pyconnect.codecs.point_cloud import point_cloud_layout
from pyconnect.codecs.point_cloud_cdr import cloud_cdr, writes_in_one_pass
from pyconnect.codecs.stamped import Stamped, stamped_header
from pyconnect.codecs.type_code import WireCode
from pyconnect.errors import CodecNotFoundError, DecodeError, EncodeError, type_name_of


class ValueCodecs(Protocol):
    """What a wire codec needs of its registry: the user or natural codec of a type, if any,
    and the dict codec that reads the message of a user codec without ``to_fields``."""

    def value_codec(self, type_ref: object) -> Codec | None: ...

    def fields_codec(self, type_ref: object) -> NaturalCodec | None: ...

    def lookup_dict(self, type_ref: object) -> DictCodec: ...


class WireCodec:
    """The CDR codec of one message type: ``decode``/``encode`` natural values, dicts, views."""

    __slots__ = ("_big", "_definitions", "_little", "_registry", "_short", "msg_type", "type_hash")

    def __init__(self, code: WireCode, *, registry: ValueCodecs) -> None:
        self.msg_type = code.full_name
        self.type_hash = code.type_hash
        self._little = code.little
        self._big = code.big
        self._definitions = code.definitions
        self._registry = registry
        self._short = code.full_name.rsplit("/", 1)[-1]

    def __repr__(self) -> str:
        return f"WireCodec({self.msg_type!r}, type_hash={self.type_hash!r})"

    @property
    def definitions(self) -> Mapping[str, Any]:
        """Type name -> (RIHS01 hash, field rows) of this type and the types it nests: the rows
        (name, kind, element, bound, container, size, default) its functions were made from."""
        return self._definitions

    # -- decoding -----------------------------------------------------------------------------
    def _decode(self, data: Any, little: DecodeFunction, big: DecodeFunction) -> Any:
        try:
            mv, is_little = body_of(data)
        except DecodeError as error:  # the header's errors name the type like the others
            raise DecodeError(f"{self.msg_type}: {error}") from None
        except TypeError as error:  # memoryview's words name neither the type nor the input
            raise DecodeError(f"{self.msg_type}: {_not_cdr(data, error)}") from None
        lim = len(mv)
        try:
            value, end = (little if is_little else big)(mv, 0, lim)
        except WireDecodeError as error:
            raise DecodeError(f"{self.msg_type}{error.path}: {error.detail}") from None
        if lim - end > 3 and lim > self._estimate(value):
            raise DecodeError(
                f"{self.msg_type}: {lim - end} bytes after the end of the message "
                "(at most 3 bytes of padding may follow it)"
            )
        return value

    def _estimate(self, value: Any) -> int:
        # rclpy's serialize_message pads to Fast DDS's size estimate (see fastdds_size).
        estimate = fastdds_estimated_size(value, self.msg_type, self._definitions)
        return (estimate + 3) & -4

    def to_dict(self, data: Any) -> dict[str, Any]:
        """The lossless dict (numeric and byte arrays as numpy views of ``data``)."""
        result: dict[str, Any] = self._decode(data, self._little.to_dict, self._big.to_dict)
        return result

    def decode_view(self, data: Any) -> Any:
        """A light view object with attributes named as the ROS fields."""
        return self._decode(data, self._little.to_view, self._big.to_view)

    def decode(
        self, data: Any, *, natural: bool = True, registry: ValueCodecs | None = None
    ) -> Any:
        """The natural value (the registry's user or natural codec on a view), else the dict."""
        if natural:
            codec = (registry or self._registry).value_codec(self.msg_type)
            if codec is not None:
                return codec.decode(self.decode_view(data))
        return self.to_dict(data)

    # -- encoding -----------------------------------------------------------------------------
    def from_dict(self, data: Mapping[str, Any], *, big_endian: bool = False) -> bytes:
        """CDR bytes (little-endian unless ``big_endian``) of a lossless dict.

        Missing keys take the field defaults; numpy arrays and scalars are accepted; wrong
        types, out-of-range values, unknown keys and over-long sequences raise ``EncodeError``
        naming the path (``JointState.position[3]: expected float, got str``).
        """
        out: list[Any] = [HEADER_BE if big_endian else HEADER_LE]
        try:
            end = (self._big if big_endian else self._little).from_dict(data, out, 0)
        except FieldError as error:
            error.root = self._short
            raise
        pad = -end & 3
        if pad:
            out.append(ZEROS[pad])
        return b"".join(out)

    def encode(self, value: Any, *, registry: ValueCodecs | None = None) -> bytes:
        """CDR bytes of the natural value (through the codec's ``to_fields``): for a type without
        a natural codec, its lossless dict (a dict for the others goes through ``from_dict``).

        A user codec without ``to_fields`` (only ``encode``/``decode``) builds its message, whose
        lossless dict is then written: that path needs the message classes (rclpy).
        """
        registry = registry or self._registry
        if isinstance(value, Stamped):
            return self.from_dict(self._stamped_fields(value, registry))
        codec = registry.value_codec(self.msg_type)
        if codec is not None:
            natural = registry.fields_codec(self.msg_type)
            if natural is None:
                return self.from_dict(self._fields_of_message(codec, value, registry))
            if writes_in_one_pass(natural, value):
                fields, points = point_cloud_layout(value)
                return cloud_cdr(self, fields, points)
            value = natural.to_fields(value)
        return self.from_dict(value)

    def _stamped_fields(self, stamped: Stamped[Any], registry: ValueCodecs) -> dict[str, Any]:
        """The fields of a ``Stamped`` value: its value's, with its stamp and frame in the
        header (as ``codecs.encode`` writes them into the message; a Header is its own)."""
        if self.msg_type == "std_msgs/msg/Header":
            return stamped_header(stamped)
        header = next(
            (
                field[0]
                for field in self._definitions[self.msg_type][1]
                if field[2] == "std_msgs/msg/Header" and field[4] == "single"
            ),
            None,
        )
        if header is None:
            raise EncodeError(
                f"{self.msg_type}: has no std_msgs/Header, so it cannot take a Stamped"
            )
        codec = registry.value_codec(self.msg_type)
        natural = registry.fields_codec(self.msg_type)
        if natural is not None:
            fields = dict(natural.to_fields(stamped.value))
        elif codec is not None:
            fields = self._fields_of_message(codec, stamped.value, registry)
        else:
            fields = dict(stamped.value)
        fields[header] = stamped_header(stamped)
        return fields

    def _fields_of_message(self, codec: Codec, value: Any, registry: ValueCodecs) -> dict[str, Any]:
        # The codec's only way to write a value is its message: read that back as fields.
        name = type(codec).__name__
        try:
            dict_codec = registry.lookup_dict(self.msg_type)
        except (ImportError, CodecNotFoundError) as error:
            raise EncodeError(
                f"{self.msg_type}: codec {name} has no to_fields(value), and the message its "
                f"encode builds cannot be read without the type's class ({error}); give the "
                "codec to_fields(value) or encode the lossless dict with from_dict"
            ) from error
        msg = codec.encode(value)
        if not isinstance(msg, dict_codec.msg_class):
            raise EncodeError(
                f"{self.msg_type}: codec {name}.encode returned {type(msg).__name__}, "
                f"expected a {self.msg_type} message"
            )
        return dict_codec.to_dict(msg)


def _not_cdr(data: Any, error: TypeError) -> str:
    try:
        memoryview(data)
    except TypeError:
        return f"expected bytes-like CDR data, got {type_name_of(data)}"
    return f"expected contiguous bytes-like CDR data: {error}"
