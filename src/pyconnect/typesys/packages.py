"""Where interface definitions live: the ament indexes of installed packages, and bare folders."""

from __future__ import annotations

import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path

INTERFACE_SUFFIXES = (".msg", ".srv", ".action")


def ament_prefixes() -> list[Path]:
    """Install prefixes holding an ament index: AMENT_PREFIX_PATH, then this interpreter's.

    The ROS wheels put the index under the venv's ``share/`` and leave AMENT_PREFIX_PATH unset,
    so ``ament_index_python`` raises there; a sourced ROS install sets the variable.
    """
    candidates = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    candidates += [Path(sys.prefix), Path(sys.base_prefix)]
    # Then prefixes whose site-packages is on sys.path: a `codecgen build --compile --prefix P`
    # install used through PYTHONPATH=P/lib/pythonX.Y/site-packages.
    for entry in sys.path:
        site = Path(entry)
        if site.name in ("site-packages", "dist-packages") and site.parent.name.startswith("py"):
            candidates.append(site.parent.parent.parent)
    found: list[Path] = []
    for prefix in candidates:
        index = prefix / "share" / "ament_index" / "resource_index" / "rosidl_interfaces"
        if index.is_dir() and prefix not in found:
            found.append(prefix)
    return found


@dataclass(frozen=True)
class InstalledPackage:
    """An interface package found in an ament index, with its IDL files (relative to share/pkg)."""

    name: str
    share: Path
    idl_files: tuple[str, ...]


def installed_packages() -> dict[str, InstalledPackage]:
    """Every interface package the ament indexes list; earlier prefixes win, as in ament."""
    packages: dict[str, InstalledPackage] = {}
    for prefix in ament_prefixes():
        index = prefix / "share" / "ament_index" / "resource_index" / "rosidl_interfaces"
        for entry in sorted(index.iterdir()):
            if entry.name in packages:
                continue
            lines = entry.read_text(encoding="utf-8").split()
            idl = tuple(sorted(line for line in lines if line.endswith(".idl")))
            packages[entry.name] = InstalledPackage(entry.name, prefix / "share" / entry.name, idl)
    return packages


_PACKAGE_NAME = re.compile(r"<name>\s*([A-Za-z][A-Za-z0-9_]*)\s*</name>")


def folder_package_name(folder: Path) -> str:
    """A bare folder's package: package.xml's <name>, else the folder's own name."""
    manifest = folder / "package.xml"
    if manifest.is_file():
        match = _PACKAGE_NAME.search(manifest.read_text(encoding="utf-8"))
        if match:
            return match.group(1)
    return folder.resolve().name


def folder_interface_files(folder: Path) -> list[Path]:
    """The .msg/.srv/.action files of a bare folder (msg/, srv/, action/ or the folder itself)."""
    files: list[Path] = []
    for sub in ("msg", "srv", "action"):
        files += sorted((folder / sub).glob(f"*.{sub}")) if (folder / sub).is_dir() else []
    files += sorted(p for p in folder.iterdir() if p.suffix in INTERFACE_SUFFIXES and p.is_file())
    return files
