"""Run generated source at run time: compiled once per text, with ``linecache`` for tracebacks.

The one place where pyconnect executes code it rendered itself (codecs compiled on the fly,
from installed definitions, installed classes or a bag's definition text). The source comes
from our own templates over the type model, never from outside.
"""

from __future__ import annotations

import hashlib
import linecache
import re
import threading
from typing import Any

Namespace = dict[str, Any]

_lock = threading.Lock()
_modules: dict[str, Namespace] = {}


def run_generated_source(source: str, *, label: str) -> Namespace:
    """The namespace of ``source`` executed as a module; the same text runs once per process.

    ``label`` names it in tracebacks (``<pyconnect generated wire codecs sensor_msgs>``).
    """
    key = hashlib.sha256(source.encode("utf-8")).hexdigest()
    with _lock:
        namespace = _modules.get(key)
        if namespace is None:
            filename = f"<pyconnect generated {label}>"
            linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
            namespace = {"__name__": "pyconnect_onthefly." + re.sub(r"\W+", "_", label)}
            exec(compile(source, filename, "exec"), namespace)
            _modules[key] = namespace
        return namespace
