"""The codec search path: folders of generated codecs outside the checked-in ``generated/``.

``pyconnect_generated`` (the package ``codecgen build`` writes) is extended, on import and on
``refresh()``, with ``<folder>/pyconnect_generated`` for each folder of

1. ``$PYCONNECT_CODEC_PATH`` (``os.pathsep``-separated): the folders you gave
   ``codecgen build --out``;
2. ``<entry>/pyconnect_codecs`` for every ``sys.path`` entry: where
   ``codecgen build --compile`` installs a compiled package's codecs, next to the package.

So generated modules of any package import as ``pyconnect_generated.<pkg>.<module>`` and link
to the checked-in modules of their dependencies, in editable and regular installs alike.
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import MutableSequence
from pathlib import Path
from typing import TypeVar

ENV_VAR = "PYCONNECT_CODEC_PATH"
CODECS_FOLDER = "pyconnect_codecs"
GENERATED_PACKAGE = "pyconnect_generated"
# `extend` returns the very object it is given, typed as given: a package's
# `__path__ = extend(__path__)` keeps the `list[str]` mypy knows `__path__` as.
PathList = TypeVar("PathList", bound=MutableSequence[str])


def codec_folders() -> list[str]:
    """Every existing ``pyconnect_generated`` folder of the search path, in order."""
    candidates = [
        Path(entry) / GENERATED_PACKAGE
        for entry in os.environ.get(ENV_VAR, "").split(os.pathsep)
        if entry
    ]
    candidates += [
        Path(entry or os.curdir) / CODECS_FOLDER / GENERATED_PACKAGE
        for entry in sys.path
        if isinstance(entry, str)
    ]
    found: list[str] = []
    for candidate in candidates:
        folder = str(candidate.resolve())
        if candidate.is_dir() and folder not in found:
            found.append(folder)
    return found


def extend(package_path: PathList) -> PathList:
    """``package_path`` (a ``__path__``) with the search path's folders appended, in place."""
    for folder in codec_folders():
        if folder not in package_path:
            package_path.append(folder)
    return package_path


def refresh() -> None:
    """Pick up codec folders created since ``pyconnect_generated`` was imported."""
    module = sys.modules.get(GENERATED_PACKAGE)
    if module is None:
        return
    extend(module.__path__)
    importlib.invalidate_caches()
