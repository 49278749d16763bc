"""Where logs go: ``<root>/<node>/<YYYYmmdd-HHMMSS>/<agent>/``, with names made safe as paths."""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Iterable
from datetime import datetime
from pathlib import Path

__all__ = [
    "DEFAULT_LOG_ROOT",
    "MAX_COMPONENT",
    "default_log_root",
    "distinct_path_components",
    "make_log_dirs",
    "safe_path_component",
]

_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")
# File systems refuse names over 255 bytes (ext4, APFS, NTFS): a valid ROS name can be longer.
# 200 leaves room for the suffixes and extensions added to a component (``_2``, ``.parquet``).
MAX_COMPONENT = 200
_HASH_CHARS = 10


def default_log_root() -> Path:
    """``$PYCONNECT_LOG_DIR`` when set, else ``./pyconnect_logs`` (read at call time)."""
    configured = os.environ.get("PYCONNECT_LOG_DIR")
    return Path(configured) if configured else Path.cwd() / "pyconnect_logs"


DEFAULT_LOG_ROOT: Path = default_log_root()
"""``default_log_root()`` as it was when pyconnect was imported (public, kept for the programs
that use it); nodes call ``default_log_root()`` when they first log, so later settings count."""


def safe_path_component(name: str) -> str:
    """One directory name for a node, agent or topic name; never ``.``, ``..`` or a path.

    ROS names keep their shape: ``/robot/camera/image`` -> ``robot__camera__image``; empty,
    ``.`` and ``..`` parts are dropped (``../../x`` -> ``x``); every other character outside
    ``[A-Za-z0-9._-]`` becomes ``_``; leading dots go, so the result is never hidden. A result
    longer than ``MAX_COMPONENT`` characters (ASCII, so bytes) keeps its start and ends with
    ``-`` and a hash of the whole name, so two long names that share a start stay apart.
    """
    parts = name.replace("\\", "/").split("/")
    joined = "__".join(part for part in parts if part not in ("", ".", ".."))
    cleaned = _UNSAFE.sub("_", joined).lstrip(".")
    if len(cleaned) > MAX_COMPONENT:
        digest = hashlib.sha256(name.encode("utf-8", "surrogatepass")).hexdigest()[:_HASH_CHARS]
        cleaned = f"{cleaned[: MAX_COMPONENT - _HASH_CHARS - 1]}-{digest}"
    return cleaned or "_"


def distinct_path_components(names: Iterable[str], taken: Iterable[str] = ()) -> dict[str, str]:
    """Map each name to a ``safe_path_component`` no other name (nor ``taken``) gets.

    Names that clean to the same component (``/a/b`` and ``/a__b``; ``/cam_/info`` and
    ``/cam/_info``) would share a directory and overwrite each other's files: the first, in the
    order given, keeps the component and each later one gets a numeric suffix (``a__b_2``).
    Components are compared without case, as macOS and Windows file systems compare names.
    """
    used = {component.casefold() for component in taken}
    found: dict[str, str] = {}
    for name in names:
        if name in found:
            continue
        component = safe_path_component(name)
        unique, suffix = component, 1
        while unique.casefold() in used:
            suffix += 1
            unique = f"{component}_{suffix}"
        used.add(unique.casefold())
        found[name] = unique
    return found


def make_log_dirs(
    root: str | Path,
    node_name: str,
    agent_names: Iterable[str],
    *,
    now: datetime | None = None,
) -> dict[str, Path]:
    """Create ``<root>/<node>/<YYYYmmdd-HHMMSS>/<agent>/`` for each agent; map agent -> dir.

    Two agents whose names clean to the same component (``/a/b`` and ``a__b``) get distinct
    directories (a numeric suffix), so their files never mix.
    """
    stamp = (now or datetime.now()).strftime("%Y%m%d-%H%M%S")
    session = Path(root) / safe_path_component(node_name) / stamp
    session.mkdir(parents=True, exist_ok=True)
    dirs: dict[str, Path] = {}
    for agent, component in distinct_path_components(agent_names).items():
        directory = session / component
        directory.mkdir(exist_ok=True)
        dirs[agent] = directory
    return dirs
