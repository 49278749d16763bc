"""The codec registry: both views of every ROS type through one chain of sources.

For each type the registry keeps one record: the message codec (rclpy message <-> value), the
lossless dict codec and the wire (CDR) codec. Each is looked up on first use through one order
of sources: a codec the user registered, the natural codec (docs/design.md §4), the generated
code in ``generated/``, and code compiled on the fly from the type model (``type_code``).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from pyconnect.codecs.base import (
    ActionCodec,
    Codec,
    DictCodec,
    FieldsCodec,
    NaturalCodec,
    ServiceCodec,
    wrong_message,
)
from pyconnect.codecs.codec_checks import check_wire_message, codec_problem, interface_parts
from pyconnect.codecs.natural import NATURAL_CODECS
from pyconnect.codecs.stamped import Stamped, decode_stamped, encode_stamped
from pyconnect.codecs.type_code import (
    compiled_dict_functions,
    compiled_wire_code,
    generated_dict_functions,
    generated_has,
    generated_wire_code,
    wire_code_from_model,
)
from pyconnect.errors import CodecError, CodecNotFoundError, PyconnectError
from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.installed_types import close_names_hint, type_installed
from pyconnect.typesys.names import (
    SERVICE_PARTS,
    TypeName,
    is_interface_name,
    parse_type_name,
)

if TYPE_CHECKING:  # wire codecs import numpy, which plain lookups do not need
    from pyconnect.codecs.wire_codec import WireCodec

AnyCodec = Codec | ServiceCodec | ActionCodec
_UNSET: Any = object()


def _load_factory(spec: str) -> Callable[[], Codec]:
    module_name, _, attr = spec.partition(":")
    factory: Callable[[], Codec] = getattr(importlib.import_module(module_name), attr)
    return factory


@dataclass(slots=True)
class TypeRecord:
    """What a registry knows of one type; each view is found on first use."""

    full_name: str
    codec: AnyCodec | None = None  # the message codec: user, natural or dict
    value: Codec | None = _UNSET  # the user or natural codec; None: the value is the dict
    fields: NaturalCodec | None = None  # ``value`` when it has ``to_fields`` (the wire encodes it)
    dict_codec: DictCodec | None = None
    wire: WireCodec | None = None


class Registry:
    """Maps ROS types to codecs. ``Registry()`` is isolated; ``default_registry`` is global.

    Lookup order: a codec registered by the user, then the natural codec (docs/design.md §4), then
    the generated code, then code generated on the fly from the installed definitions.
    """

    def __init__(self, *, natural: bool = True) -> None:
        self._user: dict[str, Codec] = {}
        self._natural: dict[str, str] = dict(NATURAL_CODECS) if natural else {}
        # One cache: records by full name and by every reference as given (a class, a short
        # name), so that the per-message paths skip parsing the name; and the wire codecs of
        # definition texts, by (type, encoding, digest).
        self._records: dict[object, TypeRecord] = {}
        self._lock = threading.RLock()

    # -- registration -------------------------------------------------------------------------
    def register(self, type_ref: object, codec: Codec, *, override: bool = False) -> None:
        """Make ``codec`` the codec of ``type_ref``; a second user codec needs ``override=True``."""
        full_name = self.resolve(type_ref)
        problem = codec_problem(codec)
        if problem is not None:
            raise PyconnectError(f"register({full_name}): {problem}")
        self._check_registrable(full_name, codec)
        with self._lock:
            if full_name in self._user and not override:
                raise PyconnectError(
                    f"{full_name} already has a user codec "
                    f"({type(self._user[full_name]).__name__}); pass override=True to replace it"
                )
            self._user[full_name] = codec
            self._forget_values()

    def _check_registrable(self, full_name: str, codec: Codec) -> None:
        # A codec registered under a name no lookup reaches would be ignored silently.
        interface = interface_parts(full_name)
        if interface is not None:
            kind, parts = interface
            raise CodecError(
                f"register({full_name}): {kind} type has no messages of its own; "
                f"register the codec for one of its parts, e.g. {parts[0]} or {parts[1]}"
            )
        if not self._type_exists(full_name):
            raise CodecNotFoundError(
                f"register({full_name}): no such type: not installed, not in generated/ and not "
                f"registered by definition (wire.register_definition){close_names_hint(full_name)}"
            )
        msg_type = getattr(codec, "msg_type", None)
        try:
            codec_type = self.resolve(msg_type) if isinstance(msg_type, str) else None
        except CodecNotFoundError:
            codec_type = None
        if codec_type != full_name:
            raise CodecError(
                f"register({full_name}): codec {type(codec).__name__} has msg_type "
                f"{msg_type!r}, expected {full_name!r} (a codec converts the messages of its "
                "own msg_type)"
            )

    def _type_exists(self, full_name: str) -> bool:
        record = self._records.get(full_name)
        if record is not None and record.wire is not None:
            return True  # register_definition made it, or its wire codec was found before
        return generated_has(full_name) or type_installed(full_name)

    def unregister(self, type_ref: object) -> None:
        """Remove the user codec of ``type_ref``; lookups fall back to the built-in ones."""
        full_name = self.resolve(type_ref)
        with self._lock:
            if full_name not in self._user and not self._type_exists(full_name):
                # A misspelt name would leave the user codec in place without a word.
                raise CodecNotFoundError(
                    f"unregister({full_name}): no such type: not installed, not in generated/ "
                    "and not registered by definition (wire.register_definition)"
                    f"{close_names_hint(full_name)}"
                )
            self._user.pop(full_name, None)
            self._forget_values()

    def _forget_values(self) -> None:
        # Message codecs (and services made of them) depend on the user codecs; code does not.
        for record in self._records.values():
            record.codec = None
            record.value = _UNSET
            record.fields = None

    # -- lookup -------------------------------------------------------------------------------
    def resolve(self, type_ref: object) -> str:
        """The full ``pkg/ns/Name`` of a type reference; ``pkg/Name`` tries msg, srv, action."""
        parsed = parse_type_name(type_ref)
        if parsed.namespace is not None:
            return parsed.full()
        for namespace in ("msg", "srv", "action"):
            if _interface_exists(parsed, namespace):
                return parsed.full(namespace)
        return parsed.full("msg")

    def _record(self, type_ref: object) -> TypeRecord:
        try:
            return self._records[type_ref]
        except (KeyError, TypeError):
            pass
        full_name = self.resolve(type_ref)
        with self._lock:
            record = self._records.get(full_name)
            if record is None:
                record = self._records[full_name] = TypeRecord(full_name)
            with contextlib.suppress(TypeError):  # unhashable references are not cached
                self._records[type_ref] = record
            return record

    def lookup(self, type_ref: object) -> AnyCodec:
        """The codec for a message type, or the composite codec of a service or action."""
        record = self._record(type_ref)
        codec = record.codec
        if codec is None:
            with self._lock:
                codec = record.codec
                if codec is None:
                    codec = record.codec = self._find(record.full_name)
        return codec

    def lookup_message(self, type_ref: object) -> Codec:
        """Like ``lookup`` but for message types only (parts of services and actions included)."""
        codec = self.lookup(type_ref)
        if isinstance(codec, ServiceCodec | ActionCodec):
            raise CodecNotFoundError(
                f"{codec.msg_type} is a service or action; name one of its parts "
                f"({', '.join(codec.parts)})"
            )
        return codec

    def lookup_service(self, type_ref: object) -> ServiceCodec:
        """The codecs of a service's parts (``.request``, ``.response``, ``.event``)."""
        codec = self.lookup(type_ref)
        if not isinstance(codec, ServiceCodec):
            raise CodecNotFoundError(f"{codec.msg_type} is not a service type")
        return codec

    def lookup_action(self, type_ref: object) -> ActionCodec:
        """The codecs of an action's parts (``.goal``, ``.result``, ``.feedback``)."""
        codec = self.lookup(type_ref)
        if not isinstance(codec, ActionCodec):
            raise CodecNotFoundError(f"{codec.msg_type} is not an action type")
        return codec

    def value_codec(self, type_ref: object) -> Codec | None:
        """The user or natural codec of a message type, or None when its value is the plain dict.

        Needs no message class: the wire codecs use it to decode CDR to natural values.
        """
        record = self._record(type_ref)
        value = record.value
        if value is _UNSET:
            with self._lock:
                value = record.value
                if value is _UNSET:
                    value = self._value_of(record.full_name)
                    # Checked once here: a runtime protocol check costs microseconds.
                    record.fields = value if isinstance(value, NaturalCodec) else None
                    record.value = value
        return value

    def fields_codec(self, type_ref: object) -> NaturalCodec | None:
        """The user or natural codec of a message type if it has ``to_fields``, else None."""
        record = self._record(type_ref)
        if record.value is _UNSET:
            self.value_codec(type_ref)
        return record.fields

    def _value_of(self, full_name: str) -> Codec | None:
        if full_name in self._user:
            return self._user[full_name]
        if full_name in self._natural:
            codec = _load_factory(self._natural[full_name])()
            if isinstance(codec, FieldsCodec):
                # Its encode is the generated message code on its fields: this registry's.
                codec.use_registry(self)
            return codec
        return None

    def lookup_dict(self, type_ref: object) -> DictCodec:
        """The lossless dict codec of a message type, whatever natural codec it has."""
        record = self._record(type_ref)
        codec = record.dict_codec
        if codec is None:
            with self._lock:
                codec = record.dict_codec
                if codec is None:
                    full_name = record.full_name
                    functions = generated_dict_functions(full_name) or compiled_dict_functions(
                        full_name
                    )
                    codec = record.dict_codec = DictCodec(full_name, *functions)
        return codec

    def wire_codec(
        self, type_ref: object, *, definition: str | None = None, encoding: str = "ros2msg"
    ) -> WireCodec:
        """The CDR codec of a message type; with ``definition``, as that text defines it."""
        if definition is not None:
            return self._definition_wire_codec(str(type_ref), definition, encoding)
        record = self._record(type_ref)
        codec = record.wire
        if codec is None:
            with self._lock:
                codec = record.wire
                if codec is None:
                    full_name = record.full_name
                    check_wire_message(full_name)
                    from pyconnect.codecs.wire_codec import WireCodec

                    code = generated_wire_code(full_name) or compiled_wire_code(full_name)
                    codec = record.wire = WireCodec(code, registry=self)
        return codec

    def register_definition(
        self, msg_type: str, text: str, *, encoding: str = "ros2msg"
    ) -> WireCodec:
        """Compile ``msg_type`` from a definition text and make it the wire codec its name finds."""
        with self._lock:
            codec = self.wire_codec(msg_type, definition=text, encoding=encoding)
            record = self._records.get(codec.msg_type)
            if record is None:
                record = self._records[codec.msg_type] = TypeRecord(codec.msg_type)
            record.wire = codec
            package, namespace, name = codec.msg_type.split("/")
            aliases = {msg_type} | ({f"{package}/{name}"} if namespace == "msg" else set())
            for alias in aliases:
                self._records[alias] = record
            return codec

    def _definition_wire_codec(self, msg_type: str, text: str, encoding: str) -> WireCodec:
        digest = hashlib.sha256(text.encode("utf-8")).hexdigest()
        key = ("definition", msg_type, encoding, digest)
        known = self._records.get(key)
        if known is not None and known.wire is not None:
            return known.wire
        with self._lock:
            from pyconnect.codecs.wire_codec import WireCodec
            from pyconnect.typesys.definition_text import resolve_definition
            from pyconnect.typesys.parse import require_rosidl

            try:
                require_rosidl()  # missing parsers are no fault of the definition: said apart
            except DefinitionError as error:
                raise CodecNotFoundError(f"{msg_type}: {error}") from None
            try:
                msg, types = resolve_definition(msg_type, text, encoding)
            except DefinitionError as error:
                raise CodecNotFoundError(
                    f"{msg_type}: bad {encoding} definition: {error}"
                ) from None
            codec: WireCodec | None = None
            if msg.type_hash and generated_has(msg.full_name):
                # The same type as the one generated: share its code.
                codec = self.wire_codec(msg.full_name)
                codec = codec if codec.type_hash == msg.type_hash else None
            if codec is None:
                codec = WireCodec(wire_code_from_model(msg, types), registry=self)
            self._records[key] = TypeRecord(msg.full_name, wire=codec)
            return codec

    def _find(self, full_name: str) -> AnyCodec:
        package, namespace, name = full_name.split("/")
        if namespace in ("srv", "action") and is_interface_name(name):
            prefix = f"{package}/{namespace}/{name}_"
            if namespace == "srv":
                request, response, event = (prefix + part for part in SERVICE_PARTS)
                return ServiceCodec(
                    full_name,
                    request=self.lookup_message(request),
                    response=self.lookup_message(response),
                    event=self.lookup_message(event) if self._has_dict(event) else None,
                )
            return ActionCodec(
                full_name,
                goal=self.lookup_message(prefix + "Goal"),
                result=self.lookup_message(prefix + "Result"),
                feedback=self.lookup_message(prefix + "Feedback"),
            )
        value = self.value_codec(full_name)
        return value if value is not None else self.lookup_dict(full_name)

    def _has_dict(self, full_name: str) -> bool:
        try:
            self.lookup_dict(full_name)
        except CodecNotFoundError:
            return False
        return True

    # -- conveniences -------------------------------------------------------------------------
    def decode(self, msg: Any, *, stamped: bool = False) -> Any:
        """Decode a ROS message with its codec; ``stamped=True`` wraps it in ``Stamped``."""
        try:
            codec = self.lookup_message(type(msg))
        except CodecNotFoundError:
            if isinstance(msg, type):  # decode(Image): the metaclass names no type
                raise wrong_message(msg, "a message") from None
            raise
        if stamped:
            return decode_stamped(codec, msg)
        return codec.decode(msg)

    def encode(self, value: Any, type_ref: object) -> Any:
        """Encode ``value`` to a new message of ``type_ref``; a ``Stamped`` fills the header."""
        codec = self.lookup_message(type_ref)
        if isinstance(value, Stamped):
            return encode_stamped(codec, value)
        return codec.encode(value)

    def to_dict(self, msg: Any) -> dict[str, Any]:
        """The lossless plain dict of any message."""
        try:
            codec = self.lookup_dict(type(msg))
        except CodecNotFoundError:
            if isinstance(msg, type):
                raise wrong_message(msg, "a message") from None
            raise
        return codec.to_dict(msg)

    def from_dict(self, data: Mapping[str, Any], type_ref: object) -> Any:
        """A new message of ``type_ref`` built from a plain dict (missing keys take defaults)."""
        return self.lookup_dict(type_ref).from_dict(data)


def _interface_exists(parsed: TypeName, namespace: str) -> bool:
    try:
        module = importlib.import_module(f"{parsed.package}.{namespace}")
    except ImportError:
        return generated_has(parsed.full(namespace))
    return hasattr(module, parsed.name)


default_registry = Registry()
