"""Where interface definitions live: the ament indexes of installed packages (with the RIHS01
hashes their type descriptions hold), and bare folders."""

from __future__ import annotations

import functools
import json
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.names import split_part

INTERFACE_SUFFIXES = (".msg", ".srv", ".action")
INTERFACE_NAMESPACES = ("msg", "srv", "action")


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


@functools.lru_cache(maxsize=1)
def installed_share_dirs() -> dict[str, Path]:
    """Package name -> share folder of every installed interface package, read once a process."""
    return {name: package.share for name, package in installed_packages().items()}


@functools.lru_cache(maxsize=1024)
def installed_type_hash(full_name: str) -> str | None:
    """The RIHS01 hash of ``pkg/ns/Name`` as installed: from the type description rosidl's build
    writes beside the definition (``share/pkg/ns/Name.json``, the service's or action's file for
    their parts), None when there is none."""
    package, namespace, name = full_name.split("/")
    part = split_part(namespace, name)
    interface = part[0] if part is not None else name
    share = installed_share_dirs().get(package)
    if share is None:
        return None
    try:
        description = json.loads((share / namespace / f"{interface}.json").read_bytes())
        hashes = {h["type_name"]: h["hash_string"] for h in description["type_hashes"]}
    except (OSError, ValueError, KeyError, TypeError):  # no description (older ROS), unreadable
        return None
    found = hashes.get(full_name)
    return found if isinstance(found, str) else None


_PACKAGE_NAME = re.compile(r"<name>\s*([A-Za-z][A-Za-z0-9_]*)\s*</name>")
# The namespace module of an IDL file: ``module pkg { module msg {`` (comments removed first).
_IDL_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.DOTALL)
_IDL_NAMESPACE = re.compile(r"\bmodule\s+\w+\s*\{\s*module\s+(\w+)\s*\{")


def read_text_file(path: Path) -> str:
    """The text of a definition file or manifest; one that is not UTF-8 is a ``DefinitionError``."""
    data = path.read_bytes()
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        line = data.count(b"\n", 0, error.start) + 1
        bad = data[error.start : error.end].hex(" ")
        raise DefinitionError(f"not UTF-8 text (bytes {bad})", path=path, line=line) from None


def folder_package_name(folder: Path) -> str:
    """A bare folder's package: package.xml's <name>, else the folder's own name."""
    manifest = folder / "package.xml"
    if manifest.is_file():
        match = _PACKAGE_NAME.search(read_text_file(manifest))
        if match:
            return match.group(1)
    return folder.resolve().name


def folder_interface_files(folder: Path) -> list[Path]:
    """The interface files of a bare folder: .msg/.srv/.action and .idl files in msg/, srv/,
    action/ or the folder itself.

    An .idl file beside a .msg/.srv/.action file of the same name is left out: it is what
    rosidl_adapter made of that file (an installed share/ folder holds both), not a second type.
    """
    candidates: list[Path] = []
    for sub in INTERFACE_NAMESPACES:
        if (folder / sub).is_dir():
            candidates += sorted((folder / sub).glob(f"*.{sub}"))
            candidates += sorted((folder / sub).glob("*.idl"))
    candidates += sorted(
        p for p in folder.iterdir() if p.suffix in (*INTERFACE_SUFFIXES, ".idl") and p.is_file()
    )
    sources = {(p.parent, p.stem) for p in candidates if p.suffix != ".idl"}
    return [p for p in candidates if p.suffix != ".idl" or (p.parent, p.stem) not in sources]


def interface_namespace(path: Path) -> str:
    """``msg``, ``srv`` or ``action``: a file's suffix, or for an .idl file its folder (msg/, srv/,
    action/) or, beside them, the namespace module it declares (rosidl's build needs it)."""
    if path.suffix != ".idl":
        return path.suffix[1:]
    if path.parent.name in INTERFACE_NAMESPACES:
        return path.parent.name
    match = _IDL_NAMESPACE.search(_IDL_COMMENT.sub(" ", read_text_file(path)))
    if match is None or match.group(1) not in INTERFACE_NAMESPACES:
        raise DefinitionError(
            "declares no `module <package> { module msg|srv|action { } }`", path=path
        )
    return match.group(1)
