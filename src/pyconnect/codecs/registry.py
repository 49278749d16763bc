"""The codec registry: finds the codec of any ROS type (user → natural → generated → on the fly)."""

from __future__ import annotations

import contextlib
import importlib
import threading
from collections.abc import Callable, Mapping
from typing import Any

from pyconnect.codecs.base import ActionCodec, Codec, DictCodec, ServiceCodec
from pyconnect.codecs.natural import NATURAL_CODECS
from pyconnect.codecs.stamped import Stamped, decode_stamped, encode_stamped
from pyconnect.errors import CodecNotFoundError, PyconnectError
from pyconnect.typesys.names import TypeName, parse_type_name

AnyCodec = Codec | ServiceCodec | ActionCodec


def _load_factory(spec: str) -> Callable[[], Codec]:
    module_name, _, attr = spec.partition(":")
    factory: Callable[[], Codec] = getattr(importlib.import_module(module_name), attr)
    return factory


def _generated_dict_codec(full_name: str) -> DictCodec | None:
    """The checked-in generated codec, if there is one and it matches the installed class."""
    package = full_name.split("/", 1)[0]
    try:
        module = importlib.import_module(f"pyconnect_generated.{package}.dict_codecs")
    except ModuleNotFoundError as error:
        # No generated module, or the ROS package it was generated from is not installed here.
        if error.name is not None and error.name.split(".")[0] in ("pyconnect_generated", package):
            return None
        raise
    entry = module.DICT_CODECS.get(full_name)
    if entry is None:
        return None
    msg_class, to_dict, from_dict, field_types = entry
    # A sourced ROS install may carry another version of the package than the one generated/
    # was made from; the generated code reads slots, so it must describe the same fields.
    if msg_class.get_fields_and_field_types() != field_types:
        return None
    return DictCodec(full_name, msg_class, to_dict, from_dict)


def _on_the_fly_dict_codec(full_name: str) -> DictCodec:
    from pyconnect.codecs.onthefly_dict import compile_dict_codec

    msg_class, to_dict, from_dict = compile_dict_codec(full_name)
    return DictCodec(full_name, msg_class, to_dict, from_dict)


class Registry:
    """Maps ROS types to codecs. ``Registry()`` is isolated; ``default_registry`` is global.

    Lookup order: a codec registered by the user, then the natural codec (DESIGN.md §4), then
    the generated dict codec, then a dict codec generated on the fly from the installed class.
    """

    def __init__(self, *, natural: bool = True) -> None:
        self._user: dict[str, Codec] = {}
        self._natural: dict[str, str] = dict(NATURAL_CODECS) if natural else {}
        self._cache: dict[str, AnyCodec] = {}
        self._dict_cache: dict[str, DictCodec] = {}
        # value_codec is asked once per decoded CDR message: cache by the reference as given.
        self._value_cache: dict[object, Codec | None] = {}
        self._lock = threading.RLock()

    # -- registration -------------------------------------------------------------------------
    def register(self, type_ref: object, codec: Codec, *, override: bool = False) -> None:
        """Make ``codec`` the codec of ``type_ref``; a second user codec needs ``override=True``."""
        full_name = self.resolve(type_ref)
        if not isinstance(codec, Codec):
            raise PyconnectError(
                f"register({full_name}): expected a codec with msg_type, lossless, encode and "
                f"decode, got {type(codec).__name__}"
            )
        with self._lock:
            if full_name in self._user and not override:
                raise PyconnectError(
                    f"{full_name} already has a user codec "
                    f"({type(self._user[full_name]).__name__}); pass override=True to replace it"
                )
            self._user[full_name] = codec
            self._cache.clear()
            self._value_cache.clear()

    def unregister(self, type_ref: object) -> None:
        """Remove the user codec of ``type_ref``; lookups fall back to the built-in ones."""
        full_name = self.resolve(type_ref)
        with self._lock:
            self._user.pop(full_name, None)
            self._cache.clear()
            self._value_cache.clear()

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

    def lookup(self, type_ref: object) -> AnyCodec:
        """The codec for a message type, or the composite codec of a service or action."""
        full_name = self.resolve(type_ref)
        cached = self._cache.get(full_name)
        if cached is not None:
            return cached
        with self._lock:
            codec = self._find(full_name)
            self._cache[full_name] = codec
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
        try:
            return self._value_cache[type_ref]
        except (KeyError, TypeError):
            pass
        full_name = self.resolve(type_ref)
        found: Codec | None = None
        if full_name in self._user:
            found = self._user[full_name]
        elif full_name in self._natural:
            cached = self._cache.get(full_name)
            if cached is None:
                cached = _load_factory(self._natural[full_name])()
                self._cache[full_name] = cached
            found = self._as_message_codec(cached)
        with contextlib.suppress(TypeError):  # unhashable references are not cached
            self._value_cache[type_ref] = found
        return found

    def lookup_dict(self, type_ref: object) -> DictCodec:
        """The lossless dict codec of a message type, whatever natural codec it has."""
        full_name = self.resolve(type_ref)
        cached = self._dict_cache.get(full_name)
        if cached is not None:
            return cached
        with self._lock:
            codec = _generated_dict_codec(full_name) or _on_the_fly_dict_codec(full_name)
            self._dict_cache[full_name] = codec
            return codec

    def _find(self, full_name: str) -> AnyCodec:
        package, namespace, name = full_name.split("/")
        # Interface names are CamelCase without underscores; the names of their parts
        # (SetBool_Request, Fibonacci_SendGoal_Request, ...) always have one.
        if namespace in ("srv", "action") and "_" not in name:
            prefix = f"{package}/{namespace}/{name}_"
            if namespace == "srv":
                event = self._find(prefix + "Event") if self._has_event(prefix) else None
                return ServiceCodec(
                    full_name,
                    request=self._as_message_codec(self._find(prefix + "Request")),
                    response=self._as_message_codec(self._find(prefix + "Response")),
                    event=self._as_message_codec(event) if event is not None else None,
                )
            return ActionCodec(
                full_name,
                goal=self._as_message_codec(self._find(prefix + "Goal")),
                result=self._as_message_codec(self._find(prefix + "Result")),
                feedback=self._as_message_codec(self._find(prefix + "Feedback")),
            )
        if full_name in self._user:
            return self._user[full_name]
        if full_name in self._natural:
            return _load_factory(self._natural[full_name])()
        return self.lookup_dict(full_name)

    def _has_event(self, prefix: str) -> bool:
        try:
            self.lookup_dict(prefix + "Event")
        except CodecNotFoundError:
            return False
        return True

    @staticmethod
    def _as_message_codec(codec: AnyCodec | None) -> Codec:
        if isinstance(codec, ServiceCodec | ActionCodec) or codec is None:
            raise CodecNotFoundError(f"{codec!r} is not a message codec")
        return codec

    # -- conveniences -------------------------------------------------------------------------
    def decode(self, msg: Any, *, stamped: bool = False) -> Any:
        """Decode a ROS message with its codec; ``stamped=True`` wraps it in ``Stamped``."""
        codec = self.lookup_message(type(msg))
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
        return self.lookup_dict(type(msg)).to_dict(msg)

    def from_dict(self, data: Mapping[str, Any], type_ref: object) -> Any:
        """A new message of ``type_ref`` built from a plain dict (missing keys take defaults)."""
        return self.lookup_dict(type_ref).from_dict(data)


def _interface_exists(parsed: TypeName, namespace: str) -> bool:
    try:
        module = importlib.import_module(f"{parsed.package}.{namespace}")
    except ImportError:
        return _generated_has(parsed.full(namespace))
    return hasattr(module, parsed.name)


def _generated_has(full_name: str) -> bool:
    package = full_name.split("/", 1)[0]
    try:
        module = importlib.import_module(f"pyconnect_generated.{package}.index")
    except ImportError:
        return False
    names: frozenset[str] = module.TYPE_NAMES
    return full_name in names


default_registry = Registry()
