"""Map rosidl_parser's definition objects onto the type model (fields, constants, defaults)."""

from __future__ import annotations

import ast
import math
import re
from collections.abc import Iterable
from pathlib import Path
from typing import Any, NamedTuple

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.model import (
    ActionDef,
    Constant,
    DefaultValue,
    ElementType,
    Field,
    FieldType,
    MessageDef,
    ServiceDef,
)
from pyconnect.typesys.primitives import FLOAT32_OVERFLOW, FLOAT_NAMES, FROM_IDL, INTEGER_RANGES

DUMMY_MEMBER = "structure_needs_at_least_one_member"
# IDL basic types with no .msg spelling, which pyconnect's codecs do not read or write.
UNSUPPORTED_IDL = "IDL char, wchar and long double are not supported; use uint8, uint16, float64"


def _of(member: str | None) -> str:
    return f" of {member}" if member is not None else ""


def element_type_of(rosidl_type: Any, origin: Path, member: str | None = None) -> ElementType:
    """The model's element type; ``member`` (the field or constant) locates an error's line."""
    from rosidl_parser import definition as d

    if isinstance(rosidl_type, d.BasicType):
        name = FROM_IDL.get(rosidl_type.typename)
        if name is None:
            raise DefinitionError(
                f"unsupported IDL type {rosidl_type.typename!r}{_of(member)} ({UNSUPPORTED_IDL})",
                path=origin,
                member=member,
            )
        return ElementType("primitive", name)
    if isinstance(rosidl_type, d.AbstractWString):
        bound = rosidl_type.maximum_size if isinstance(rosidl_type, d.BoundedWString) else None
        return ElementType("wstring", "wstring", int(bound) if bound is not None else None)
    if isinstance(rosidl_type, d.AbstractString):
        bound = rosidl_type.maximum_size if isinstance(rosidl_type, d.BoundedString) else None
        return ElementType("string", "string", int(bound) if bound is not None else None)
    if isinstance(rosidl_type, d.NamespacedType):
        return ElementType("message", "/".join(rosidl_type.namespaced_name()))
    raise DefinitionError(
        f"unsupported IDL type {rosidl_type!r}{_of(member)}", path=origin, member=member
    )


def field_type_of(rosidl_type: Any, origin: Path, member: str | None = None) -> FieldType:
    from rosidl_parser import definition as d

    if isinstance(rosidl_type, d.Array):
        element = element_type_of(rosidl_type.value_type, origin, member)
        return FieldType(element, "array", rosidl_type.size)
    if isinstance(rosidl_type, d.BoundedSequence):
        element = element_type_of(rosidl_type.value_type, origin, member)
        return FieldType(element, "bounded_sequence", rosidl_type.maximum_size)
    if isinstance(rosidl_type, d.UnboundedSequence):
        return FieldType(element_type_of(rosidl_type.value_type, origin, member), "sequence")
    return FieldType(element_type_of(rosidl_type, origin, member))


# rosidl writes defaults and constants into the C and Python code as literals (`inff`, `inf`),
# which do not compile: a colcon build fails on them, so the model refuses them up front.
_NOT_FINITE = "is not finite"
_WHY = "(rosidl's generated code cannot spell inf or nan)"


class _Subject(NamedTuple):
    """What a default or constant value belongs to, for errors: ``the default of speed``."""

    role: str
    name: str
    origin: Path

    def error(self, problem: str) -> DefinitionError:
        return DefinitionError(
            f"the {self.role} of {self.name} {problem}", path=self.origin, member=self.name
        )


def _scalar(value: object, element: ElementType, subject: _Subject) -> bool | int | float | str:
    if element.kind in ("string", "wstring"):
        text = str(value)
        bound = element.string_bound
        if bound is not None and len(text) > bound:
            spelling = f"{element.name}<={bound}"
            raise subject.error(
                f"is too long for {spelling}: {text!r} ({len(text)} characters, at most {bound})"
            )
        return text
    if isinstance(value, str):
        value = _literal(value, element, subject)
    if element.name == "bool":
        # IDL's TRUE/FALSE, or 1/0 as .msg allows; rosidl's generators would turn any other
        # value (2, "false") into a bool by its truth, which is not what the text says.
        if isinstance(value, bool) or (isinstance(value, int) and value in (0, 1)):
            return bool(value)
        raise subject.error(_not_a(element, value))
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise subject.error(_not_a(element, value))
    if element.is_float:
        number = float(value)
        if not math.isfinite(number):
            raise subject.error(f"{_NOT_FINITE}: {number} {_WHY}")
        # rosidl would store it as inf, and every message leaving the field out would carry a
        # value no float32 check lets a user give: refused here, where the text is at fault.
        if element.name == "float32" and abs(number) >= FLOAT32_OVERFLOW:
            raise subject.error(
                f"is out of float32's range: {number!r} (|x| < {FLOAT32_OVERFLOW!r})"
            )
        return number
    # An IDL float literal (1.7, 1e3) is not an integer: rosidl's generated Python code would
    # refuse it, its C code would truncate it.
    if not isinstance(value, int):
        raise subject.error(_not_a(element, value))
    low, high = INTEGER_RANGES[element.name]
    if not low <= value <= high:
        raise subject.error(f"is out of {element.name}'s range: {value!r} ({low} <= x <= {high})")
    return value


def _not_a(element: ElementType, value: object) -> str:
    article = "an" if element.name[0] in "aeiou" else "a"
    problem = f"is not {article} {element.name} value: {value!r}"
    expected = _EXPECTED.get(element.name)
    return problem if expected is None else f"{problem} ({expected})"


_EXPECTED = {
    "bool": "expected TRUE, FALSE, 1 or 0",
    **dict.fromkeys(FLOAT_NAMES, "expected a number"),
    **dict.fromkeys(INTEGER_RANGES, "expected an integer"),
}


def _literal(text: str, element: ElementType, subject: _Subject, *, listed: str = "") -> Any:
    """``text`` read as a Python literal, as rosidl writes them; ``listed`` is the spelling of
    the array or sequence type it is the default of, if any."""
    # rosidl keeps as text what it could not read as a number: inf, nan, a list holding them.
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        if element.is_float and re.search(r"(?i)\b(inf|infinity|nan)\b", text):
            raise subject.error(f"{_NOT_FINITE}: {text} {_WHY}") from None
        if listed:
            raise subject.error(f"is not a list of values for {listed}: {text!r}") from None
        raise subject.error(_not_a(element, text)) from None


def _default(member: Any, ftype: FieldType, origin: Path) -> DefaultValue:
    if not member.has_annotation("default"):
        return None
    raw = member.get_annotation_value("default")["value"]
    subject = _Subject("default", member.name, origin)
    if ftype.is_single:
        return _scalar(raw, ftype.element, subject)
    spelling = _spelling(ftype)
    values = _literal(raw, ftype.element, subject, listed=spelling) if isinstance(raw, str) else raw
    if not isinstance(values, tuple | list):
        raise subject.error(f"is not a list of values for {spelling}: {raw!r}")
    _check_length(tuple(values), ftype, subject)
    return tuple(_scalar(v, ftype.element, subject) for v in values)


def _check_length(values: tuple[object, ...], ftype: FieldType, subject: _Subject) -> None:
    count, size = len(values), ftype.size
    if ftype.is_array and count != size:
        raise subject.error(
            f"does not fit {_spelling(ftype)}: {values!r} ({count} elements, exactly {size})"
        )
    if ftype.container == "bounded_sequence" and size is not None and count > size:
        raise subject.error(
            f"is too long for {_spelling(ftype)}: {values!r} ({count} elements, at most {size})"
        )


def _spelling(ftype: FieldType) -> str:
    """The .msg spelling of a field's type (``int32[<=2]``), the model's vocabulary in errors."""
    element = ftype.element
    bound = f"<={element.string_bound}" if element.string_bound is not None else ""
    size = "" if ftype.size is None else str(ftype.size)
    brackets = {"single": "", "array": f"[{size}]", "bounded_sequence": f"[<={size}]",
                "sequence": "[]"}  # fmt: skip
    return f"{element.name}{bound}{brackets[ftype.container]}"


def _constant(constant: Any, origin: Path) -> Constant:
    element = element_type_of(constant.type, origin, constant.name)
    subject = _Subject("value", constant.name, origin)
    return Constant(constant.name, element, _scalar(constant.value, element, subject))


class MemberError(DefinitionError):
    """A fault of one field or constant (``member``) of the message rosidl names ``message``
    (``Same_Request``): the reader holding the text looks for its line in that message's part."""

    def __init__(self, error: DefinitionError, message: str) -> None:
        super().__init__(error.detail, path=error.path, member=error.member)
        self.message = message


def message_def(
    structure: Any, constants: Iterable[Any], origin: Path, python: tuple[str, str]
) -> MessageDef:
    namespaced = structure.namespaced_type
    package, namespace = namespaced.namespaces
    try:
        # Constants first: an .idl file declares them (module X_Constants) before the struct, so
        # the first fault reported is the first in the file.
        consts = tuple(_constant(c, origin) for c in constants)
        fields = []
        for member in structure.members:
            if member.name == DUMMY_MEMBER:
                continue
            ftype = field_type_of(member.type, origin, member.name)
            fields.append(Field(member.name, ftype, _default(member, ftype, origin)))
    except DefinitionError as error:
        if error.member is None or error.line is not None:
            raise
        raise MemberError(error, namespaced.name) from None
    return MessageDef(
        package=package,
        namespace=namespace,
        name=namespaced.name,
        fields=tuple(fields),
        constants=consts,
        python_module=python[0],
        python_class=python[1],
    )


def service_def(srv: Any, origin: Path, module: str, access: str) -> ServiceDef:
    package = srv.namespaced_type.namespaces[0]

    def part(message: Any, name: str) -> MessageDef:
        return message_def(message.structure, message.constants, origin, (module, name))

    request = part(srv.request_message, f"{access}.Request")
    response = part(srv.response_message, f"{access}.Response")
    event = part(srv.event_message, f"{access}.Event")
    return ServiceDef(package, srv.namespaced_type.name, request, response, event)


def action_def(action: Any, origin: Path, module: str) -> ActionDef:
    package = action.namespaced_type.namespaces[0]
    name = action.namespaced_type.name

    def part(message: Any, access: str) -> MessageDef:
        return message_def(message.structure, message.constants, origin, (module, access))

    send_goal = service_def(
        action.send_goal_service, origin, module, f"{name}.Impl.SendGoalService"
    )
    get_result = service_def(
        action.get_result_service, origin, module, f"{name}.Impl.GetResultService"
    )
    implicit = (
        *send_goal.messages,
        *get_result.messages,
        part(action.feedback_message, f"{name}.Impl.FeedbackMessage"),
    )
    return ActionDef(
        package,
        name,
        goal=part(action.goal, f"{name}.Goal"),
        result=part(action.result, f"{name}.Result"),
        feedback=part(action.feedback, f"{name}.Feedback"),
        implicit=implicit,
    )
