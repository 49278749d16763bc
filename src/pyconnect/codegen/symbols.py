"""How rendered modules name each type's functions, classes and TypedDicts, clear of each other.

A rendered module holds names the templates give (imports such as ``Struct``, constants such as
``EMPTY``) next to names derived from type names (the view or rosidl class ``Image``, the TypedDict
``ImageDict``). ROS type names are any ``[A-Z][A-Za-z0-9]*``, so a type may be called ``Struct``
or ``Any``: a derived name that would shadow one of the template's gets a trailing underscore
(``Struct_``). No type name ends with one, so the escaped name cannot meet another type's; a
TypedDict name that would shadow one, or be another type's class, becomes ``<Name>_Dict``.
Ordinary names, and so the generated output of ordinary packages, stay as they are. Two types whose
derived names still meet (``HTTPServer`` and ``HttpServer`` both make ``http_server``) cannot be
told apart and are refused (``check_type_names``), as are ``None``, ``True`` and ``False``.
"""

from __future__ import annotations

import keyword
from collections.abc import Iterable
from dataclasses import dataclass

from pyconnect.codegen.templating import snake_case
from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.model import MessageDef

# Every name shaped like a type name (or a TypedDict's) that a template binds at module level
# or reads from the builtins: a type-derived name equal to one of them is escaped. The guard
# test tests/codegen/test_type_names.py parses the generated modules and fails on any such
# name missing here, so a template change cannot bring the shadowing back unnoticed.
RESERVED: frozenset[str] = frozenset(
    {
        # imports of the templates
        "Any", "Callable", "FieldError", "Mapping", "Struct", "TypedDict", "WireDecodeError",
        # module-level constants of the templates (EMPTY, ZEROS also imported)
        "BIG", "DEFINITIONS", "EMPTY", "EXPORTED", "FUNCTIONS", "LITTLE", "MISSING", "ZEROS",
        # the byte order parameter of the wire module's _build (a local, kept clear regardless)
        "E",
        # builtins the generated code reads (None, True and False are refused: check_type_names)
        "Exception", "OverflowError", "TypeError", "ValueError",
    }
)  # fmt: skip


def _escaped(name: str) -> str:
    return name + "_" if name in RESERVED else name


@dataclass(frozen=True)
class Symbols:
    """How a rendered module names the functions, classes and TypedDicts of each type.

    In a package module, the package's own types use short names and other packages' types are
    imported under qualified aliases; a self-contained (on-the-fly) module qualifies everything.
    ``type_names`` holds ``(package, name)`` of the types whose TypedDict names are asked for:
    a TypedDict is not given a name another type of its package has as its class (``Foo``'s
    would be ``FooDict`` beside a type ``FooDict``; the dict module imports both).
    """

    local_package: str | None
    type_names: frozenset[tuple[str, str]] = frozenset()

    def _qualified(self, msg_full_name: str) -> bool:
        package = msg_full_name.split("/", maxsplit=1)[0]
        return self.local_package is None or package != self.local_package

    def function(self, full_name: str) -> str:
        package, _, name = full_name.split("/")
        base = snake_case(name)
        return f"{package}__{base}" if self._qualified(full_name) else base

    def cls(self, full_name: str) -> str:
        package, namespace, name = full_name.split("/")
        return f"{package}__{namespace}__{name}" if self._qualified(full_name) else _escaped(name)

    def typed_dict(self, full_name: str) -> str:
        package, _, name = full_name.split("/")
        stem = name.replace("_", "")
        base = stem + "Dict"
        # "_Dict" rather than a trailing underscore: ``Typed``'s TypedDict must not meet the
        # escaped class ``TypedDict_`` of a type named ``TypedDict``; no class ends in "_Dict".
        if base in RESERVED or (package, base) in self.type_names:
            base = stem + "_Dict"
        return f"{package}__{base}" if self._qualified(full_name) else base


def check_type_names(messages: Iterable[MessageDef], symbols: Symbols) -> None:
    """Refuse what no module can name: types that one module would name alike (the second
    would silently replace the first), and keywords. rosidl's Python generator puts two messages
    whose names snake-case alike in one ``_<snake>.py`` module too, and cannot define a class
    named ``None``, so such a package does not work in ROS either."""
    owners: dict[str, MessageDef] = {}
    for msg in messages:
        if keyword.iskeyword(msg.name.partition("_")[0]):
            raise DefinitionError(
                "a Python keyword cannot name a type (rosidl's Python class could not be defined)",
                path=msg.full_name,
            )
        # Functions and key sets derive from the snake-case name; the dict module imports the
        # TypedDicts beside the classes, so both share one name space.
        snake = snake_case(msg.name)
        names = {
            f"{symbols.function(msg.full_name)}_from_dict": snake,
            symbols.cls(msg.full_name): symbols.cls(msg.full_name),
            symbols.typed_dict(msg.full_name): symbols.typed_dict(msg.full_name),
        }
        for name, shown in names.items():
            other = owners.setdefault(name, msg)
            if other.full_name == msg.full_name:
                continue
            same_module = shown == snake and other.namespace == msg.namespace == "msg"
            why = f" (rosidl would put both in one module _{snake}.py)" if same_module else ""
            raise DefinitionError(
                f"its generated name {shown!r} is also that of {other.full_name}{why}: "
                "rename one of them",
                path=msg.full_name,
            )
