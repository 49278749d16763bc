"""ROS type names: parse every way users name a type, and the names of service and action parts.

Users name a type by class, instance, ``"pkg/msg/Name"`` or ``"pkg/Name"``. Services and
actions have implicit message types (``SetBool_Request``, ``Fibonacci_SendGoal_Request``...):
the rules for those names, and for the rosidl Python class that holds each part, live here;
so do the field and constant names a compiled package cannot have.
"""

from __future__ import annotations

import keyword
import re
from dataclasses import dataclass

from pyconnect.errors import CodecNotFoundError

_NAME = re.compile(r"^([A-Za-z][A-Za-z0-9_]*)/(?:(msg|srv|action)/)?([A-Za-z][A-Za-z0-9_]*)$")


@dataclass(frozen=True)
class TypeName:
    """A parsed ROS interface name. ``namespace`` is None when the user left it out."""

    package: str
    namespace: str | None
    name: str

    def full(self, namespace: str | None = None) -> str:
        return f"{self.package}/{namespace or self.namespace or 'msg'}/{self.name}"


def parse_type_name(type_ref: object) -> TypeName:
    """Parse a class, a message instance or a string into a ``TypeName``.

    Classes and instances are named by the module rosidl generated them in
    (``std_srvs.srv._set_bool.SetBool_Request`` -> ``std_srvs/srv/SetBool_Request``).
    """
    if isinstance(type_ref, str):
        match = _NAME.match(type_ref.strip())
        if match is None:
            raise CodecNotFoundError(
                f"{type_ref!r} is not a ROS type name: expected 'pkg/msg/Name' or 'pkg/Name'"
            )
        package, namespace, name = match.groups()
        return TypeName(package, namespace, name)
    cls = type_ref if isinstance(type_ref, type) else type(type_ref)
    module = getattr(cls, "__module__", "") or ""
    parts = module.split(".")
    if len(parts) >= 2 and parts[1] in ("msg", "srv", "action"):
        return TypeName(parts[0], parts[1], cls.__name__)
    raise CodecNotFoundError(f"{cls.__qualname__} (module {module!r}) is not a ROS interface class")


def full_type_name(type_ref: object) -> str:
    """The canonical ``pkg/ns/Name`` of any type reference; ``pkg/Name`` means a message."""
    return parse_type_name(type_ref).full()


# -- service and action parts ------------------------------------------------------------------
SERVICE_PARTS = ("Request", "Response", "Event")
# Action part suffix -> the dotted path of its class under the action's class.
ACTION_PARTS: dict[str, str] = {
    "Goal": "Goal",
    "Result": "Result",
    "Feedback": "Feedback",
    "FeedbackMessage": "Impl.FeedbackMessage",
    "SendGoal_Request": "Impl.SendGoalService.Request",
    "SendGoal_Response": "Impl.SendGoalService.Response",
    "SendGoal_Event": "Impl.SendGoalService.Event",
    "GetResult_Request": "Impl.GetResultService.Request",
    "GetResult_Response": "Impl.GetResultService.Response",
    "GetResult_Event": "Impl.GetResultService.Event",
}


def is_interface_name(name: str) -> bool:
    """True for a service or action's own name: CamelCase never has the ``_`` its parts have."""
    return "_" not in name


def split_part(namespace: str, name: str) -> tuple[str, str] | None:
    """(interface name, part suffix) of a service or action part's name, else None.

    ``split_part("action", "Fibonacci_SendGoal_Request") == ("Fibonacci", "SendGoal_Request")``
    """
    suffixes = (
        SERVICE_PARTS
        if namespace == "srv"
        else tuple(ACTION_PARTS)
        if namespace == "action"
        else ()
    )
    for suffix in sorted(suffixes, key=len, reverse=True):
        if name.endswith("_" + suffix) and len(name) > len(suffix) + 1:
            return name[: -len(suffix) - 1], suffix
    return None


def class_path(full_name: str) -> tuple[str, str]:
    """(module, dotted attribute path) of the rosidl Python class of a message type."""
    package, namespace, name = full_name.split("/")
    module = f"{package}.{namespace}"
    part = split_part(namespace, name)
    if part is None:
        return module, name
    interface, suffix = part
    return module, f"{interface}.{ACTION_PARTS[suffix] if namespace == 'action' else suffix}"


# -- field and constant names ------------------------------------------------------------------
# Words a compiled interface package cannot use as a field or constant name: rosidl copies the
# names verbatim into Python classes (a keyword is a SyntaxError on import; rosidl_generator_py
# only warns), C structs and the C++ sources of the type supports, which include those structs.
_C_KEYWORDS = frozenset((
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else",
    "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register",
    "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch", "typedef",
    "union", "unsigned", "void", "volatile", "while",
    # C23
    "alignas", "alignof", "bool", "constexpr", "false", "nullptr", "static_assert",
    "thread_local", "true", "typeof", "typeof_unqual",
))  # fmt: skip
_CPP_KEYWORDS = frozenset((
    "and", "and_eq", "asm", "bitand", "bitor", "catch", "char8_t", "char16_t", "char32_t",
    "class", "compl", "concept", "consteval", "constinit", "const_cast", "co_await", "co_return",
    "co_yield", "decltype", "delete", "dynamic_cast", "explicit", "export", "friend", "mutable",
    "namespace", "new", "noexcept", "not", "not_eq", "operator", "or", "or_eq", "private",
    "protected", "public", "reinterpret_cast", "requires", "static_cast", "template", "this",
    "throw", "try", "typeid", "typename", "using", "virtual", "wchar_t", "xor", "xor_eq",
))  # fmt: skip


# Names rosidl_generator_py's message template (resource/_msg.py.em) itself uses in the class,
# each checked by compiling a package that has it: the import or every use then fails.
_PYTHON_CLASS_NAMES = {
    "builtins": "the module the Python class rosidl generates takes its property decorator "
    "from (a field after it makes the class not import)",
    "get_fields_and_field_types": "a method of the Python class rosidl generates (the field "
    "would replace it: printing the message and pyconnect's codecs fail)",
    "SLOT_TYPES": "an attribute of the Python class rosidl generates (the constant would hide "
    "it: pyconnect cannot read the type from the class)",
}
# Object-like macros of gcc on Linux and of the headers rosidl's generated C includes (Python.h,
# numpy's, glibc's): the preprocessor rewrites a struct member named so into something that is
# no name. Function-like ones (``assert``) and ones defined as themselves (``stdin``) are
# harmless; each of these was checked by compiling a package that has it.
_C_MACROS = frozenset((
    "linux", "unix", "errno", "complex", "constchar", "longdouble_t", "math_errhandling",
    "st_atime", "st_ctime", "st_mtime",
))  # fmt: skip
# The C types of rosidl's structs: a member named after one changes its meaning in the struct,
# which the C++ type supports (they include the struct) refuse.
_C_TYPES = frozenset(f"{sign}int{bits}_t" for sign in ("", "u") for bits in (8, 16, 32, 64))


def compiled_name_problem(name: str) -> str | None:
    """Why a field or constant called ``name`` breaks a compiled package, or None if it does not.

    Only compiled packages need this: pyconnect's own generated code escapes every name.
    """
    if keyword.iskeyword(name):
        return "a Python keyword (the Python class rosidl generates would not import)"
    if name in _PYTHON_CLASS_NAMES:
        return _PYTHON_CLASS_NAMES[name]
    if name in _C_KEYWORDS:
        return "a C keyword (the C code rosidl generates would not compile)"
    if name in _CPP_KEYWORDS:
        return "a C++ keyword (the C++ type support rosidl generates would not compile)"
    if name in _C_MACROS:
        return "a C macro on Linux (the C code rosidl generates would not compile)"
    if name in _C_TYPES:
        return "a C type of rosidl's structs (the C++ type support would not compile)"
    return None
