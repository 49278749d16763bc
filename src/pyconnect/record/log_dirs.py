"""Where logs go: ``<root>/<node>/<YYYYmmdd-HHMMSS>/<agent>/``, with names made safe as paths."""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from datetime import datetime
from pathlib import Path

__all__ = ["DEFAULT_LOG_ROOT", "default_log_root", "make_log_dirs", "safe_path_component"]

_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")


def default_log_root() -> Path:
    """``$PYCONNECT_LOG_DIR`` when set, else ``./pyconnect_logs`` (read at call time)."""
    configured = os.environ.get("PYCONNECT_LOG_DIR")
    return Path(configured) if configured else Path.cwd() / "pyconnect_logs"


DEFAULT_LOG_ROOT: Path = default_log_root()


def safe_path_component(name: str) -> str:
    """One directory name for a node, agent or topic name; never ``.``, ``..`` or a path.

    ROS names keep their shape: ``/robot/camera/image`` -> ``robot__camera__image``; empty,
    ``.`` and ``..`` parts are dropped (``../../x`` -> ``x``); every other character outside
    ``[A-Za-z0-9._-]`` becomes ``_``; leading dots go, so the result is never hidden.
    """
    parts = name.replace("\\", "/").split("/")
    joined = "__".join(part for part in parts if part not in ("", ".", ".."))
    cleaned = _UNSAFE.sub("_", joined).lstrip(".")
    return cleaned or "_"


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
    taken: set[str] = set()
    for agent in agent_names:
        if agent in dirs:
            continue
        component = safe_path_component(agent)
        unique, suffix = component, 1
        while unique in taken:
            suffix += 1
            unique = f"{component}_{suffix}"
        taken.add(unique)
        directory = session / unique
        directory.mkdir(exist_ok=True)
        dirs[agent] = directory
    return dirs
