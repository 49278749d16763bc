"""Service and action parts in .msg form, read under stand-in names rosidl's .msg parser accepts.

rosidl_adapter parses .msg text only into ``pkg/msg/...`` and refuses both the field type
``pkg/action/Fibonacci_Feedback`` and part names such as ``SetBool_Event`` or
``Fibonacci_SendGoal_Request``. A definition text may still hold such parts (pyconnect writes
action parts that way, with ``MSG: pkg/action/Name`` blocks): each is parsed as
``pkg/msg/PyconnectPart<n>`` and then renamed, in the model and in rosidl's own objects, so that
its RIHS01 hash is computed under its real name, as rosidl's build computes it.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path
from typing import Any

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.model import ElementType, Field, MessageDef, Namespace
from pyconnect.typesys.names import class_path
from pyconnect.typesys.parse import ParsedInterfaces

__all__ = ["PartStandIns"]

_PART_NAMESPACES: dict[str, Namespace] = {"srv": "srv", "action": "action"}
# A .msg field whose type is a service or action part: `pkg/action/Name[...] field`.
_PART_FIELD_TYPE = re.compile(
    r"^([ \t]*)([A-Za-z][A-Za-z0-9_]*)/(srv|action)/([A-Za-z][A-Za-z0-9_]*)(?=[\s\[])",
    re.MULTILINE,
)


class PartStandIns:
    """The stand-in names given to the service and action parts of one definition text."""

    def __init__(self, text: str) -> None:
        self._text = text  # a stand-in must be a name the text does not use
        self._stand_in: dict[tuple[str, str, str], str] = {}  # (pkg, ns, name) -> stand-in
        self._real: dict[str, tuple[Namespace, str]] = {}  # "pkg/msg/<stand-in>" -> (ns, name)
        self._by_stem: dict[str, tuple[Namespace, str]] = {}  # "<stand-in>" -> (ns, name)
        self._next = 0  # the number of the next stand-in, PyconnectPart<n>

    def name(self, package: str, namespace: str, name: str) -> str:
        """The stand-in under which ``package/namespace/name`` (a srv or action part) is parsed
        in ``msg``."""
        key = (package, namespace, name)
        found = self._stand_in.get(key)
        if found is None:
            part_namespace = _PART_NAMESPACES[namespace]
            while re.search(rf"\bPyconnectPart{self._next}\b", self._text):
                self._next += 1
            found = self._stand_in[key] = f"PyconnectPart{self._next}"
            self._next += 1
            self._real[f"{package}/msg/{found}"] = self._by_stem[found] = (part_namespace, name)
        return found

    def respell(self, text: str) -> str:
        """A .msg text whose part field types (``pkg/action/Name``) name their stand-ins."""

        def stand_in(match: re.Match[str]) -> str:
            indent, package, namespace, name = match.groups()
            return f"{indent}{package}/{self.name(package, namespace, name)}"

        return _PART_FIELD_TYPE.sub(stand_in, text)

    def real_error(self, error: DefinitionError) -> DefinitionError:
        """``error`` of a parse, with each stand-in (its file's name included) named for real."""
        if not self._real:
            return error
        detail, path = self._real_names(error.detail), error.path
        if path is not None:
            # The file is named after the type it holds: msg/<stand-in>.msg.
            stand_in = Path(path)
            real = self._by_stem.get(stand_in.stem)
            if real is not None:
                path = Path(real[0]) / f"{real[1]}{stand_in.suffix}"
        return DefinitionError(detail, path=path, line=error.line, member=error.member)

    def _real_names(self, text: str) -> str:
        for full, (namespace, name) in self._real.items():
            package, _, stand_in = full.split("/")
            real = f"{package}/{namespace}/{name}"
            text = re.sub(rf"\b{package}/(msg/)?{stand_in}\b", real, text)
            text = re.sub(rf"\b{stand_in}\b", name, text)
        return text

    def rename(self, parsed: ParsedInterfaces) -> None:
        """Give the stand-ins of ``parsed`` (the text's types only) their real names."""
        if not self._real:
            return
        from rosidl_parser import definition as d

        for element in parsed.rosidl_elements:
            if isinstance(element, d.Message):
                self._retarget(element.structure.namespaced_type)
                for member in element.structure.members:
                    self._retarget(member.type)
        parsed.messages = [self._renamed(m) for m in parsed.messages]
        parsed.origins = {
            self._real_full_name(full): self._real_origin(full, origin)
            for full, origin in parsed.origins.items()
        }

    def _retarget(self, rosidl_type: Any) -> None:
        from rosidl_parser import definition as d

        if isinstance(rosidl_type, d.AbstractNestedType):
            self._retarget(rosidl_type.value_type)
        elif isinstance(rosidl_type, d.NamespacedType):
            real = self._real.get("/".join(rosidl_type.namespaced_name()))
            if real is not None:
                rosidl_type.namespaces = [rosidl_type.namespaces[0], real[0]]
                rosidl_type.name = real[1]

    def _real_full_name(self, full_name: str) -> str:
        real = self._real.get(full_name)
        package = full_name.split("/", maxsplit=1)[0]
        return full_name if real is None else f"{package}/{real[0]}/{real[1]}"

    def _real_origin(self, full_name: str, origin: Path) -> Path:
        real = self._real.get(full_name)
        return origin if real is None else Path(real[0]) / f"{real[1]}{origin.suffix}"

    def _renamed(self, msg: MessageDef) -> MessageDef:
        fields = tuple(self._renamed_field(f) for f in msg.fields)
        real = self._real.get(msg.full_name)
        if real is None:
            return replace(msg, fields=fields)
        module, path = class_path(f"{msg.package}/{real[0]}/{real[1]}")
        return replace(
            msg,
            namespace=real[0],
            name=real[1],
            fields=fields,
            python_module=module,
            python_class=path,
        )

    def _renamed_field(self, fld: Field) -> Field:
        element = fld.type.element
        if element.kind != "message" or element.name not in self._real:
            return fld
        renamed = ElementType("message", self._real_full_name(element.name))
        return replace(fld, type=replace(fld.type, element=renamed))
