"""``codecgen build --compile``: a folder of .msg/.srv/.action/.idl files to an installed package.

What a colcon build of a ``rosidl_generate_interfaces`` package installs, made from Python in one
command: rosidl's generators (``codegen.compile_generate``), the system compiler
(``codegen.compile_link``), then an install into the active environment or ``--prefix``
(``codegen.compile_install``). Folders are built in dependency order; unchanged input is a no-op
(a digest of the inputs is stored with the install); everything is built in a temporary folder
and moved into place at the end, so a failed build leaves the previous install untouched.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import sys
import tempfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from pyconnect.codegen import FORMAT_VERSION
from pyconnect.codegen.build import render_loaded
from pyconnect.codegen.compile_dependents import installed_type_hashes
from pyconnect.codegen.compile_generate import Dependency, adapt_interfaces, run_generators
from pyconnect.codegen.compile_install import (
    InstallLayout,
    StagedPackage,
    check_replaceable,
    install_staged,
    read_stamp,
)
from pyconnect.codegen.compile_link import build_libraries, relative_rpath
from pyconnect.codegen.compile_toolchain import find_toolchain
from pyconnect.codegen.package_order import build_order, referenced_packages, type_reference
from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.loading import load_packages
from pyconnect.typesys.model import PackageDef, TypeSet
from pyconnect.typesys.packages import (
    folder_interface_files,
    folder_package_name,
    installed_packages,
)

# Bump when the build recipe changes, so that installs made by an older recipe are rebuilt.
RECIPE_VERSION = "1"
_DEPEND_TAGS = re.compile(
    r"<(?:depend|build_depend|exec_depend|build_export_depend)>\s*([A-Za-z0-9_]+)\s*</"
)
_VERSION_TAG = re.compile(r"<version>\s*([^<\s]+)\s*</version>")


@dataclass(frozen=True)
class BuildResult:
    """What happened to one package: ``built`` or ``up to date``, and where it went;
    ``changed_types`` when it replaced an install whose type hashes were other ones."""

    package: str
    status: str
    layout: InstallLayout
    changed_types: bool = False


@contextlib.contextmanager
def _prefix_visible(prefix: Path) -> Iterator[None]:
    """Make ``prefix`` the first ament prefix while building (packages built into it resolve)."""
    previous = os.environ.get("AMENT_PREFIX_PATH")
    parts = [str(prefix), *(previous.split(os.pathsep) if previous else [])]
    os.environ["AMENT_PREFIX_PATH"] = os.pathsep.join(dict.fromkeys(parts))
    try:
        yield
    finally:
        if previous is None:
            del os.environ["AMENT_PREFIX_PATH"]
        else:
            os.environ["AMENT_PREFIX_PATH"] = previous


def _manifest_dependencies(folder: Path) -> list[str]:
    manifest = folder / "package.xml"
    if not manifest.is_file():
        return []
    return _DEPEND_TAGS.findall(manifest.read_text(encoding="utf-8"))


def _manifest_version(folder: Path) -> str:
    manifest = folder / "package.xml"
    if manifest.is_file():
        match = _VERSION_TAG.search(manifest.read_text(encoding="utf-8"))
        if match:
            return match.group(1)
    return "0.0.0"


def resolve_dependencies(names: set[str]) -> list[Dependency]:
    """The installed interface packages among ``names`` (others, e.g. build tools, are skipped)."""
    installed = installed_packages()
    return [
        Dependency(name, installed[name].share, installed[name].idl_files)
        for name in sorted(names)
        if name in installed and installed[name].idl_files
    ]


def _digest(folder: Path, package: PackageDef, files: Sequence[Path]) -> str:
    digest = hashlib.sha256(f"{RECIPE_VERSION}/{FORMAT_VERSION}/{sys.version}".encode())
    for path in [*files, folder / "package.xml"]:
        if path.is_file():
            digest.update(path.relative_to(folder).as_posix().encode() + b"\0")
            digest.update(path.read_bytes() + b"\0")
    # Own hashes cover every definition the package refers to (RIHS01 is recursive).
    for msg in package.all_messages:
        digest.update(f"{msg.full_name}={msg.type_hash}\n".encode())
    return digest.hexdigest()


def compile_folders(
    folders: Sequence[Path], *, prefix: Path | None = None, force: bool = False
) -> list[BuildResult]:
    """Build and install each folder's interface package (dependencies first)."""
    layout = InstallLayout.for_prefix(prefix)
    with _prefix_visible(layout.prefix):
        by_name: dict[str, Path] = {}
        for given in folders:
            folder = Path(given)
            if not folder.is_dir():
                raise DefinitionError("no such folder", path=folder)
            by_name[folder_package_name(folder)] = folder
        requested, types = load_packages(folders=list(by_name.values()), compiled=True)
        needs = {
            name: referenced_packages(requested[name], types)
            | set(_manifest_dependencies(by_name[name]))
            for name in by_name
        }

        def why(name: str, other: str) -> str:
            return type_reference(requested[name], other, types) or (
                f"{name}'s package.xml depends on {other}"
            )

        order = build_order(needs, why=why, where=lambda name: by_name[name])
        results = []
        for name in order:
            before = installed_type_hashes(layout, name)
            result = _compile_one(by_name[name], requested[name], types, needs[name], layout, force)
            if before and result.status == "built":
                changed = installed_type_hashes(layout, name) != before
                result = replace(result, changed_types=changed)
            results.append(result)
        return results


def _compile_one(  # noqa: PLR0917  (one private call site)
    folder: Path,
    package: PackageDef,
    types: TypeSet,
    needs: set[str],
    layout: InstallLayout,
    force: bool,
) -> BuildResult:
    files = folder_interface_files(folder)
    digest = _digest(folder, package, files)
    python_dir = layout.python / package.name
    if not force and python_dir.is_dir() and read_stamp(layout, package.name) == digest:
        return BuildResult(package.name, "up to date", layout)
    check_replaceable(layout, package.name)  # before minutes of compiling, not after
    toolchain = find_toolchain([layout.prefix])
    dependencies = resolve_dependencies(needs - {package.name})
    layout.prefix.mkdir(parents=True, exist_ok=True)
    build = Path(tempfile.mkdtemp(prefix=f".codecgen-{package.name}-", dir=layout.prefix))
    try:
        stage = layout.staged(build / "stage")
        idl_files = adapt_interfaces(package.name, folder, files, build)
        sources = run_generators(
            package=package.name,
            build=build,
            idl_files=idl_files,
            interface_files=files,
            dependencies=dependencies,
            prefixes=toolchain.prefixes,
        )
        staged_python = stage.python / package.name
        shutil.copytree(sources.output("rosidl_generator_py"), staged_python)
        for leftover in staged_python.rglob("*.c"):
            leftover.unlink()
        build_libraries(
            sources=sources,
            dependencies=[d.name for d in dependencies],
            toolchain=toolchain,
            lib_dir=stage.lib,
            python_dir=staged_python,
            lib_rpath_from_python=relative_rpath(python_dir, layout.lib),
        )
        staged = StagedPackage(
            name=package.name,
            version=_manifest_version(folder),
            folder=folder,
            interface_files=tuple(files),
            idl_files=tuple(idl_files),
            sources=sources,
            codec_files=render_loaded([package], types),
            run_dependencies=tuple(d.name for d in dependencies),
            digest=digest,
        )
        install_staged(staged, stage, layout)
    finally:
        shutil.rmtree(build, ignore_errors=True)
    return BuildResult(package.name, "built", layout)
