"""The code of one type: the checked-in generated modules first, else rendered and run on the fly.

Both views of a type come from here: the dict functions (rclpy message <-> lossless dict) and the
wire functions (CDR <-> dict or view). Code compiled on the fly is rendered by the same renderer
as ``codecgen build`` from the type model, which comes from the installed definitions, the
installed classes, or a bag's definition text, never from generated code.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Any, NamedTuple

from pyconnect.codecs.generated_source import Namespace, run_generated_source
from pyconnect.errors import CodecNotFoundError
from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.model import MessageDef, TypeSet
from pyconnect.typesys.packages import installed_type_hash

if TYPE_CHECKING:  # the CDR runtime imports numpy, which plain lookups do not need
    from pyconnect.codecs.cdr_read import DecodeFunction
    from pyconnect.codecs.cdr_write import EncodeFunction
    from pyconnect.codecs.fastdds_size import Definitions


class DictFunctions(NamedTuple):
    """The generated dict codec of a message type: its rclpy class and the two conversions."""

    msg_class: type
    to_dict: Callable[[Any], dict[str, Any]]
    from_dict: Callable[[Mapping[str, Any]], Any]


class WireFunctions(NamedTuple):
    """The generated CDR functions of a type for one byte order."""

    to_dict: DecodeFunction
    to_view: DecodeFunction
    from_dict: EncodeFunction


@dataclass(frozen=True)
class WireCode:
    """The CDR functions of a type in both byte orders, with what the size estimate needs."""

    full_name: str
    type_hash: str
    little: WireFunctions
    big: WireFunctions
    definitions: Definitions


# -- generated modules ----------------------------------------------------------------------------
def generated_module(full_name: str, kind: str) -> ModuleType | None:
    """``pyconnect_generated.<package>.<kind>`` of a type's package, or None when there is none.

    None too when the type's own ROS package is not installed (the on-the-fly path then says
    so). Any other import failure (a dependency's classes missing, a namespace package of
    sources shadowing the installed one) is a ``CodecNotFoundError`` naming the type, the module
    and the original error: the generated code exists but cannot run here.
    """
    package = full_name.split("/", 1)[0]
    module = f"pyconnect_generated.{package}.{kind}"
    try:
        return importlib.import_module(module)
    except ImportError as error:
        # No generated module (another package's generated code missing too: on the fly
        # compiles it), or the ROS package it was generated from is not installed here.
        missing = error.name if isinstance(error, ModuleNotFoundError) else None
        if missing is not None and missing.split(".")[0] in ("pyconnect_generated", package):
            return None
        raise CodecNotFoundError(
            f"{full_name}: its generated codec {module} cannot be imported: {error}"
        ) from error


def generated_dict_functions(full_name: str) -> DictFunctions | None:
    """The checked-in dict codec, if there is one and it matches the installed class."""
    module = generated_module(full_name, "dict_codecs")
    entry = module.DICT_CODECS.get(full_name) if module is not None else None
    if entry is None:
        return None
    msg_class, to_dict, from_dict, field_types = entry
    # A sourced ROS install may carry another version of the package than the one generated/
    # was made from; the generated code reads slots, so it must describe the same fields.
    if msg_class.get_fields_and_field_types() != field_types:
        return None
    # Its nested types too (a stale folder on the codec search path would drop a field added
    # to one): the RIHS01 hash covers them all, one lookup as for the wire code.
    installed = installed_type_hash(full_name)
    if installed is not None and generated_hash(full_name) != installed:
        return None
    return DictFunctions(msg_class, to_dict, from_dict)


def _wire_code(full_name: str, namespace: Mapping[str, Any]) -> WireCode:
    definitions = namespace["DEFINITIONS"]
    return WireCode(
        full_name,
        definitions[full_name][0],
        little=WireFunctions(*namespace["LITTLE"][full_name]),
        big=WireFunctions(*namespace["BIG"][full_name]),
        definitions=definitions,
    )


def generated_wire_code(full_name: str) -> WireCode | None:
    """The generated wire code, if there is one and it was made from the installed type."""
    module = generated_module(full_name, "wire_codecs")
    if module is None or full_name not in module.EXPORTED:
        return None
    # Code generated from another version of the type than the installed one (a stale folder
    # on the codec search path, generated/ against a sourced install) would read and write
    # other fields: its hash, which covers every nested type, must be the installed one. A type
    # that is not installed here (a zenoh peer without ROS) has nothing to disagree with.
    installed = installed_type_hash(full_name)
    if installed is not None and module.DEFINITIONS[full_name][0] != installed:
        return None
    return _wire_code(full_name, vars(module))


def generated_has(full_name: str) -> bool:
    """True when generated/ has the type (its index lists it; nothing of ROS is imported)."""
    module = generated_module(full_name, "index")
    return module is not None and full_name in module.TYPE_NAMES


# -- compiled on the fly ------------------------------------------------------------------------
def compiled_dict_functions(full_name: str) -> DictFunctions:
    """The dict codec rendered from the installed class (``CodecNotFoundError`` if none)."""
    from pyconnect.codegen.render import render_self_contained_dict_codecs
    from pyconnect.typesys.classes import type_set_from_classes

    try:
        types = type_set_from_classes(full_name)
    except DefinitionError as error:
        raise CodecNotFoundError(f"{full_name}: {error}") from None
    except ImportError as error:
        # The class imports a package it uses when it is made (one uninstalled since).
        raise CodecNotFoundError(
            f"{full_name}: no generated codec and its class cannot be used: {error}"
        ) from error
    source = render_self_contained_dict_codecs(types.closure(full_name), types)
    namespace = run_generated_source(source, label=f"dict codecs {full_name}")
    msg_class, to_dict, from_dict, _fields = namespace["DICT_CODECS"][full_name]
    return DictFunctions(msg_class, to_dict, from_dict)


def generated_hash(full_name: str) -> str | None:
    """The RIHS01 hash of the type as generated/ has it (None when it lacks the type)."""
    module = generated_module(full_name, "index")
    return module.TYPE_HASHES.get(full_name) if module is not None else None


def _run_wire_source(messages: list[MessageDef], types: TypeSet, label: str) -> Namespace:
    from pyconnect.codegen.wire_render import render_wire_module

    # Types used here that generated/ has, hash for hash, link to its code; the rest compile.
    # ``seen`` keeps the walk finite whatever the model holds (typesys refuses recursive types).
    used = {name for msg in messages for name in msg.nested_types}
    seen = set(used)
    linked = set()
    while used:
        name = used.pop()
        msg = types.get(name)
        if msg.type_hash and generated_hash(name) == msg.type_hash:
            linked.add(name)  # its own nested types come with its module
        else:
            fresh = set(msg.nested_types) - seen
            seen |= fresh
            used |= fresh
    source = render_wire_module(messages, types, source=label, linked=linked)
    return run_generated_source(source, label=label)


def compiled_wire_code(full_name: str) -> WireCode:
    """The wire code rendered from the installed definitions of the type's package."""
    from pyconnect.typesys.loading import load_packages

    package = full_name.split("/", 1)[0]
    try:
        _requested, types = load_packages([package])
    except DefinitionError as error:
        raise CodecNotFoundError(f"{full_name}: no generated wire codec and {error}") from None
    if full_name not in types.messages:
        raise CodecNotFoundError(f"{full_name}: no such type in its installed package")
    namespace = _run_wire_source([types.get(full_name)], types, f"installed {full_name}")
    return _wire_code(full_name, namespace)


def wire_code_from_model(msg: MessageDef, types: TypeSet) -> WireCode:
    """The wire code of a type the caller read into the model (e.g. from a bag's text)."""
    namespace = _run_wire_source([msg], types, f"{msg.full_name} {msg.type_hash or 'unhashed'}")
    return _wire_code(msg.full_name, namespace)
