"""Where ``codecgen build --compile`` installs a package, and how it moves it into place.

Layout under the prefix (the active environment's ``sys.prefix`` unless ``--prefix``), as colcon
installs it: ``lib/`` (the shared libraries), ``include/<pkg>/<pkg>/`` (C headers, for packages
depending on this one), ``share/<pkg>/`` (.msg/.srv/.action, .idl, .json type descriptions,
package.xml), ``share/ament_index/resource_index/`` (the index entries), and in site-packages
the Python package ``<pkg>/``, its pyconnect codecs in
``pyconnect_codecs/pyconnect_generated/<pkg>/`` (see ``pyconnect.codecs.search_path``) and a
``<pkg>-<version>.dist-info`` whose RECORD lists every file, so ``pip uninstall <pkg>`` removes
it all. The Python package is moved into place last: while it is absent nothing imports.
Only what codecgen installed (its dist-info's INSTALLER says ``codecgen``) is ever replaced or
uninstalled: a package of the same name from pip or a ROS wheel is left alone.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import sysconfig
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from pyconnect.codegen.build import GENERATED_PACKAGE
from pyconnect.codegen.compile_generate import GeneratedSources
from pyconnect.typesys.errors import DefinitionError

# The folder pyconnect.codecs.search_path looks for in every sys.path entry.
CODECS_FOLDER = "pyconnect_codecs"
STAMP_FILE = "codecgen.stamp"  # JSON inside, but no .json suffix: tools glob those
INSTALLER = "codecgen"  # the dist-info INSTALLER text that marks an install as ours
_HEADER_GENERATORS = (
    "rosidl_generator_c", "rosidl_typesupport_fastrtps_c", "rosidl_typesupport_introspection_c",
)  # fmt: skip


@dataclass(frozen=True)
class InstallLayout:
    """The folders of one install prefix."""

    prefix: Path
    python: Path

    @classmethod
    def for_prefix(cls, prefix: Path | None) -> InstallLayout:
        root = Path(prefix).resolve() if prefix is not None else Path(sys.prefix)
        paths = sysconfig.get_paths(vars={"base": str(root), "platbase": str(root)})
        return cls(root, Path(paths["purelib"]))

    def staged(self, root: Path) -> InstallLayout:
        """The same layout under a staging folder."""
        return InstallLayout(root, root / self.python.relative_to(self.prefix))

    @property
    def lib(self) -> Path:
        return self.prefix / "lib"

    @property
    def include(self) -> Path:
        return self.prefix / "include"

    @property
    def share(self) -> Path:
        return self.prefix / "share"

    @property
    def resource_index(self) -> Path:
        return self.share / "ament_index" / "resource_index"

    def codecs(self, package: str) -> Path:
        return self.python / CODECS_FOLDER / GENERATED_PACKAGE / package


@dataclass(frozen=True)
class StagedPackage:
    """Everything built for one package, ready to be laid out and installed."""

    name: str
    version: str
    folder: Path
    interface_files: tuple[Path, ...]
    idl_files: tuple[str, ...]
    sources: GeneratedSources
    codec_files: dict[str, str]
    run_dependencies: tuple[str, ...]
    digest: str


def _stamp_entry(layout: InstallLayout, package: str, key: str) -> str | None:
    path = layout.share / package / STAMP_FILE
    try:
        stamp = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    value = stamp.get(key) if isinstance(stamp, dict) else None
    return value if isinstance(value, str) else None


def read_stamp(layout: InstallLayout, package: str) -> str | None:
    """The input digest an install was built from, or None."""
    return _stamp_entry(layout, package, "digest")


def stamp_folder(layout: InstallLayout, package: str) -> Path | None:
    """The folder an install was built from (None for installs older than this entry)."""
    folder = _stamp_entry(layout, package, "folder")
    return Path(folder) if folder is not None else None


def _copy(source: Path, target: Path) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(source, target)


def _write(target: Path, text: str) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(text, encoding="utf-8")


def _lay_out(staged: StagedPackage, stage: InstallLayout) -> None:
    name = staged.name
    for generator in _HEADER_GENERATORS:
        root = staged.sources.output(generator)
        for header in root.rglob("*.h"):
            _copy(header, stage.include / name / name / header.relative_to(root))
    share = stage.share / name
    description_root = staged.sources.output("rosidl_generator_type_description")
    idl_root = staged.sources.root("rosidl_adapter") / name
    for relative in staged.idl_files:
        _copy(idl_root / relative, share / relative)
        json_file = Path(relative).with_suffix(".json")
        _copy(description_root / json_file, share / json_file)
    interface_lines = list(staged.idl_files)
    for path in staged.interface_files:
        if path.suffix != ".idl":
            relative = f"{path.suffix[1:]}/{path.name}"
            _copy(path, share / relative)
            interface_lines.append(relative)
    manifest = staged.folder / "package.xml"
    if manifest.is_file():
        _copy(manifest, share / "package.xml")
    # The folder too: the command that rebuilds a dependent after its dependency changed names it.
    stamp = {"digest": staged.digest, "folder": str(staged.folder.resolve())}
    _write(share / STAMP_FILE, json.dumps(stamp, indent=2) + "\n")
    index = stage.resource_index
    _write(index / "rosidl_interfaces" / name, "\n".join(sorted(interface_lines)))
    _write(index / "packages" / name, "")
    _write(index / "package_run_dependencies" / name, ";".join(staged.run_dependencies))
    prefix = f"{GENERATED_PACKAGE}/{name}/"
    for relative, text in staged.codec_files.items():
        if relative.startswith(prefix):
            _write(stage.codecs(name) / relative[len(prefix) :], text)


def _dist_info_name(staged: StagedPackage) -> str:
    return f"{staged.name}-{staged.version}.dist-info"


def _write_dist_info(staged: StagedPackage, stage: InstallLayout, final: InstallLayout) -> None:
    dist_info = stage.python / _dist_info_name(staged)
    _write(
        dist_info / "METADATA",
        f"Metadata-Version: 2.1\nName: {staged.name}\nVersion: {staged.version}\n"
        f"Summary: ROS 2 interface package built by codecgen build --compile\n",
    )
    _write(dist_info / "INSTALLER", INSTALLER + "\n")
    files = sorted(p for p in stage.prefix.rglob("*") if p.is_file())
    record = [
        os.path.relpath(final.prefix / p.relative_to(stage.prefix), final.python) + ",,"
        for p in files
    ]
    record.append(f"{dist_info.name}/RECORD,,")
    _write(dist_info / "RECORD", "\n".join(record) + "\n")


def _replace(staged: Path, final: Path, trash: Path) -> None:
    """Move ``staged`` onto ``final``; an existing ``final`` goes to ``trash`` first."""
    final.parent.mkdir(parents=True, exist_ok=True)
    if final.is_dir() and not final.is_symlink():
        os.replace(final, trash / f"{len(list(trash.iterdir()))}")
    os.replace(staged, final)


def install_staged(staged: StagedPackage, stage: InstallLayout, final: InstallLayout) -> None:
    """Lay the package out under ``stage`` and move it into ``final``, Python package last.

    ``InstallConflictError`` when ``final`` holds a package of that name codecgen did not build.
    """
    check_replaceable(final, staged.name)
    _lay_out(staged, stage)
    _write_dist_info(staged, stage, final)
    trash = stage.prefix.parent / "trash"
    trash.mkdir(exist_ok=True)
    moves: list[tuple[Path, Path]] = [
        (lib, final.lib / lib.name) for lib in sorted(stage.lib.glob("*.so"))
    ]
    moves += [
        (stage.include / staged.name, final.include / staged.name),
        (stage.share / staged.name, final.share / staged.name),
        (stage.codecs(staged.name), final.codecs(staged.name)),
        (stage.python / _dist_info_name(staged), final.python / _dist_info_name(staged)),
    ]
    moves += [
        (entry, final.resource_index / entry.relative_to(stage.resource_index))
        for entry in sorted(stage.resource_index.rglob("*"))
        if entry.is_file()
    ]
    moves.append((stage.python / staged.name, final.python / staged.name))
    for source, target in moves:
        _replace(source, target, trash)
    for old in _own_dist_infos(final, staged.name):
        if old.name != _dist_info_name(staged):  # an earlier version's
            shutil.rmtree(old, ignore_errors=True)


class InstallConflictError(DefinitionError):
    """The prefix holds a package of that name codecgen did not build: it is not replaced."""


def _installer(dist_info: Path) -> str | None:
    """The INSTALLER text of a dist-info ("pip", "codecgen"...), None when it has none."""
    try:
        return (dist_info / "INSTALLER").read_text(encoding="utf-8").strip()
    except (OSError, UnicodeDecodeError):
        return None


def _own_dist_infos(layout: InstallLayout, package: str) -> list[Path]:
    """The ``<package>-*.dist-info`` folders codecgen wrote (INSTALLER says so)."""
    return [
        dist_info
        for dist_info in sorted(layout.python.glob(f"{package}-*.dist-info"))
        if _installer(dist_info) == INSTALLER
    ]


def _record_paths(layout: InstallLayout, dist_info: Path) -> list[Path] | None:
    """The files a RECORD lists, None when one lies outside the prefix or it cannot be read."""
    try:
        lines = (dist_info / "RECORD").read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return None
    paths = []
    for line in lines:
        entry = line.split(",")[0]
        if not entry:
            continue
        # RECORD paths are relative to site-packages (``../../../lib/...`` for the libraries);
        # an absolute one, or one climbing out of the prefix, is no file codecgen wrote.
        path = Path(os.path.normpath(layout.python / entry))
        if Path(entry).is_absolute() or layout.prefix not in path.parents:
            return None
        paths.append(path)
    return paths


def installed_record(layout: InstallLayout, package: str) -> list[Path]:
    """The files a compiled install of ``package`` wrote (from its RECORD), or [].

    Only a dist-info codecgen wrote counts, and only when every path it lists is inside the
    prefix: a distribution pip installed under the same name is never removed through here.
    """
    for dist_info in _own_dist_infos(layout, package):
        paths = _record_paths(layout, dist_info)
        if paths:
            return paths
    return []


def _clobbered_paths(layout: InstallLayout, package: str) -> list[Path]:
    """What an install of ``package`` would replace, where it exists already."""
    candidates = [
        layout.python / package,
        layout.share / package,
        layout.include / package,
        *(layout.resource_index / kind / package for kind in ("rosidl_interfaces", "packages")),
        *layout.lib.glob(f"lib{package}__rosidl_*.so"),
    ]
    return [path for path in candidates if path.exists() or path.is_symlink()]


def _owner(layout: InstallLayout, paths: list[Path]) -> Path | None:
    """The dist-info whose RECORD lists a file at or under one of ``paths``, if any."""
    # Compared as RECORD spells paths (relative to site-packages): a venv has ~20k lines.
    wanted = tuple(os.path.relpath(path, layout.python) for path in paths)
    under = tuple(f"{relative}/" for relative in wanted)
    for dist_info in sorted(layout.python.glob("*.dist-info")):
        try:
            lines = (dist_info / "RECORD").read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeDecodeError):
            continue
        for line in lines:
            listed = os.path.normpath(line.split(",")[0])
            if listed in wanted or listed.startswith(under):
                return dist_info
    return None


def check_replaceable(layout: InstallLayout, package: str) -> None:
    """Refuse to install ``package`` over one of that name that codecgen did not build.

    Replacing is what a rebuild does, and only codecgen's own installs may be replaced: pip's
    ``mylib`` or a ROS wheel's ``std_msgs`` would be deleted without a word otherwise.
    """
    named = sorted(layout.python.glob(f"{package}-*.dist-info"))
    foreign = [d for d in named if _installer(d) != INSTALLER]
    if not foreign and named:
        return  # codecgen's own install: rebuilt in place
    existing = _clobbered_paths(layout, package)
    if not foreign and not existing:
        return
    owner = foreign[0] if foreign else _owner(layout, existing)
    if owner is None:
        what = f"{existing[0]}, which no installed distribution lists"
    else:
        installer = _installer(owner)
        by = f"INSTALLER {installer!r}" if installer is not None else "no INSTALLER"
        what = f"the distribution {owner.name} ({by})"
    raise InstallConflictError(
        f"{package}: {layout.prefix} already has {what}, not a package built by codecgen: "
        "not replacing it (uninstall it first, or build into another --prefix)"
    )


def uninstall(layout: InstallLayout, package: str) -> list[Path]:
    """Remove every file of a compiled install and the folders it leaves empty."""
    removed = installed_record(layout, package)
    folders: set[Path] = set()
    for path in removed:
        if path.is_file() or path.is_symlink():
            path.unlink()
        folders.update(p for p in path.parents if layout.prefix in p.parents)
    for folder in sorted(folders, key=lambda p: len(p.parts), reverse=True):
        _remove_if_empty(folder, keep=(layout.prefix, layout.python, layout.lib, layout.share))
    return removed


def _remove_if_empty(folder: Path, *, keep: Iterable[Path]) -> None:
    if folder in set(keep) or not folder.is_dir():
        return
    for cache in folder.glob("__pycache__"):
        shutil.rmtree(cache, ignore_errors=True)
    if not any(folder.iterdir()):
        folder.rmdir()
