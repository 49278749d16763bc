"""The type model: frozen dataclasses describing ROS messages, services, actions and packages.

Everything a codec needs is here — primitive kinds, array and sequence bounds, string bounds,
nesting, constants, defaults and the RIHS01 type hash — so that dict codecs, TypedDicts and CDR
wire codecs are all rendered from the same description.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from pyconnect.typesys.primitives import FLOAT_NAMES, INTEGER_RANGES

ElementKind = Literal["primitive", "string", "wstring", "message"]
Container = Literal["single", "array", "bounded_sequence", "sequence"]
Namespace = Literal["msg", "srv", "action"]
DefaultValue = bool | int | float | str | tuple[bool | int | float | str, ...] | None


@dataclass(frozen=True)
class ElementType:
    """The type of one value: a primitive, a (w)string with an optional bound, or a message."""

    kind: ElementKind
    # primitive: a name from primitives.PRIMITIVE_NAMES; string/wstring: "string"/"wstring";
    # message: the full name "pkg/msg/Name".
    name: str
    string_bound: int | None = None

    @property
    def is_primitive(self) -> bool:
        return self.kind == "primitive"

    @property
    def is_float(self) -> bool:
        return self.name in FLOAT_NAMES

    @property
    def is_integer(self) -> bool:
        return self.kind == "primitive" and self.name in INTEGER_RANGES

    @property
    def is_bytes_like(self) -> bool:
        """uint8/byte/char values, whose arrays and sequences are ``bytes`` in dicts."""
        return self.name in ("uint8", "byte", "char") and self.kind == "primitive"


@dataclass(frozen=True)
class FieldType:
    """A field's element type and container: single, fixed array, bounded or unbounded sequence."""

    element: ElementType
    container: Container = "single"
    # array: the fixed length; bounded_sequence: the upper bound; otherwise None.
    size: int | None = None

    @property
    def is_single(self) -> bool:
        return self.container == "single"

    @property
    def is_array(self) -> bool:
        return self.container == "array"

    @property
    def is_sequence(self) -> bool:
        return self.container in ("bounded_sequence", "sequence")


@dataclass(frozen=True)
class Field:
    """One field of a message. ``default`` is None when the definition gives no default."""

    name: str
    type: FieldType
    default: DefaultValue = None


@dataclass(frozen=True)
class Constant:
    """A constant of a message (``int32 FOO=1``)."""

    name: str
    type: ElementType
    value: bool | int | float | str


@dataclass(frozen=True)
class MessageDef:
    """One message type, including the implicit ones of services and actions.

    ``python_class`` says how to reach the rosidl Python class: import ``python_module`` and
    follow the dotted ``python_class`` path (``SetBool.Request`` for a service part).
    An empty message has no fields here (rosidl's dummy member is dropped; CDR writes one byte).
    """

    package: str
    namespace: Namespace
    name: str
    fields: tuple[Field, ...]
    constants: tuple[Constant, ...] = ()
    type_hash: str = ""
    python_module: str = ""
    python_class: str = ""

    @property
    def full_name(self) -> str:
        return f"{self.package}/{self.namespace}/{self.name}"

    @property
    def nested_types(self) -> tuple[str, ...]:
        """Full names of the message types this one's fields refer to, in field order."""
        seen: list[str] = []
        for fld in self.fields:
            if fld.type.element.kind == "message" and fld.type.element.name not in seen:
                seen.append(fld.type.element.name)
        return tuple(seen)


@dataclass(frozen=True)
class ServiceDef:
    """A service: its request, response and (Jazzy) event messages."""

    package: str
    name: str
    request: MessageDef
    response: MessageDef
    event: MessageDef | None
    type_hash: str = ""

    @property
    def full_name(self) -> str:
        return f"{self.package}/srv/{self.name}"

    @property
    def messages(self) -> tuple[MessageDef, ...]:
        parts = (self.request, self.response)
        return parts + ((self.event,) if self.event is not None else ())


@dataclass(frozen=True)
class ActionDef:
    """An action: goal, result, feedback and the messages of its hidden services and topic."""

    package: str
    name: str
    goal: MessageDef
    result: MessageDef
    feedback: MessageDef
    implicit: tuple[MessageDef, ...] = ()
    type_hash: str = ""
    # The RIHS01 hashes of the action's implicit services (rmw_zenoh puts them in key
    # expressions): ``<pkg>/action/<Name>_SendGoal`` and ``<pkg>/action/<Name>_GetResult``.
    send_goal_hash: str = ""
    get_result_hash: str = ""

    @property
    def full_name(self) -> str:
        return f"{self.package}/action/{self.name}"

    @property
    def service_hashes(self) -> tuple[tuple[str, str], ...]:
        """(full name, hash) of the implicit SendGoal and GetResult services."""
        return (
            (f"{self.full_name}_SendGoal", self.send_goal_hash),
            (f"{self.full_name}_GetResult", self.get_result_hash),
        )

    @property
    def messages(self) -> tuple[MessageDef, ...]:
        return (self.goal, self.result, self.feedback, *self.implicit)


@dataclass(frozen=True)
class PackageDef:
    """Everything one interface package defines, sorted by name for deterministic output."""

    name: str
    messages: tuple[MessageDef, ...] = ()
    services: tuple[ServiceDef, ...] = ()
    actions: tuple[ActionDef, ...] = ()

    @property
    def all_messages(self) -> tuple[MessageDef, ...]:
        """Plain messages, then the parts of services and actions."""
        parts = [m for s in self.services for m in s.messages]
        parts += [m for a in self.actions for m in a.messages]
        return self.messages + tuple(parts)


@dataclass
class TypeSet:
    """Every message definition known to one generator run, by full name (deps included)."""

    messages: dict[str, MessageDef] = field(default_factory=dict)

    def get(self, full_name: str) -> MessageDef:
        return self.messages[full_name]

    def closure(self, full_name: str) -> list[MessageDef]:
        """``full_name`` and every type it refers to, dependencies first."""
        ordered: list[MessageDef] = []
        seen: set[str] = set()

        def visit(name: str) -> None:
            if name in seen:
                return
            seen.add(name)
            msg = self.messages[name]
            for nested in msg.nested_types:
                visit(nested)
            ordered.append(msg)

        visit(full_name)
        return ordered
