"""Dict codecs generated at run time for installed message classes that ``generated/`` lacks.

The IR is read from the class itself (rosidl keeps the parsed field types in ``SLOT_TYPES``),
rendered with the same template as ``codecgen build``, compiled once and cached. The source is
registered with ``linecache`` so that tracebacks through it show the real lines.
"""

from __future__ import annotations

import linecache
import threading
from collections.abc import Callable, Mapping
from typing import Any

from pyconnect.codegen.render import render_self_contained_dict_codecs
from pyconnect.errors import CodecNotFoundError
from pyconnect.typesys.classes import type_set_from_classes
from pyconnect.typesys.errors import DefinitionError

_lock = threading.Lock()
_compiled: dict[str, tuple[type, Callable[[Any], Any], Callable[[Mapping[str, Any]], Any]]] = {}


def compile_dict_codec(
    full_name: str,
) -> tuple[type, Callable[[Any], Any], Callable[[Mapping[str, Any]], Any]]:
    """(class, to_dict, from_dict) for ``full_name``, generated and compiled once per process."""
    cached = _compiled.get(full_name)
    if cached is not None:
        return cached
    with _lock:
        cached = _compiled.get(full_name)
        if cached is not None:
            return cached
        try:
            types = type_set_from_classes(full_name)
        except DefinitionError as error:
            raise CodecNotFoundError(f"{full_name}: {error}") from None
        source = render_self_contained_dict_codecs(types.closure(full_name), types)
        filename = f"<codecgen on-the-fly dict codecs for {full_name}>"
        linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
        namespace: dict[str, Any] = {
            "__name__": f"pyconnect_onthefly.{full_name.replace('/', '.')}"
        }
        exec(compile(source, filename, "exec"), namespace)
        for name, (cls, to_dict, from_dict, _fields) in namespace["DICT_CODECS"].items():
            _compiled.setdefault(name, (cls, to_dict, from_dict))
        return _compiled[full_name]
