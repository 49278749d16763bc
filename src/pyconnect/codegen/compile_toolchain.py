"""The C/C++ toolchain of ``codecgen build --compile``: find compilers, headers and libraries.

Only what the ROS wheels (or a sourced ROS install) put on disk is used: their ``include/`` and
``lib/`` folders under each install prefix, this interpreter's ``Python.h`` and numpy's headers.
Every problem is a ``ToolchainError`` whose text is one line saying what to install, or which
interface's generated code did not compile.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.packages import ament_prefixes

# Header-only and runtime packages the generated sources include, and the libraries they link.
RUNTIME_PACKAGES = (
    "rcutils", "rosidl_runtime_c", "rosidl_runtime_cpp", "rosidl_typesupport_interface",
    "rosidl_typesupport_c", "rosidl_typesupport_fastrtps_c", "rosidl_typesupport_fastrtps_cpp",
    "rosidl_typesupport_introspection_c", "rosidl_dynamic_typesupport", "fastcdr", "rmw",
    "rcpputils",
)  # fmt: skip


class ToolchainError(DefinitionError):
    """A compiler, header or library is missing, or compiling failed: one line, what to do."""


@dataclass(frozen=True)
class Toolchain:
    """Compilers and the include/library folders of the ROS install."""

    cc: tuple[str, ...]
    cxx: tuple[str, ...]
    prefixes: tuple[Path, ...]
    python_include: Path
    numpy_include: Path

    def include_dirs(self, packages: Iterable[str]) -> list[Path]:
        """``include/<pkg>`` of each package (the colcon layout), then each ``include/``."""
        found: list[Path] = []
        for package in packages:
            for prefix in self.prefixes:
                candidate = prefix / "include" / package
                if candidate.is_dir() and candidate not in found:
                    found.append(candidate)
                    break
        for prefix in self.prefixes:
            if (prefix / "include").is_dir() and prefix / "include" not in found:
                found.append(prefix / "include")
        return found

    def library_dirs(self) -> list[Path]:
        return [prefix / "lib" for prefix in self.prefixes if (prefix / "lib").is_dir()]

    def find_library(self, name: str) -> Path | None:
        for directory in self.library_dirs():
            candidate = directory / f"lib{name}.so"
            if candidate.exists():
                return candidate
        return None


def _compiler(variable: str, candidates: Sequence[str]) -> tuple[str, ...] | None:
    configured = os.environ.get(variable)
    if configured:
        words = tuple(shlex.split(configured))
        return words if words and shutil.which(words[0]) else None
    for name in candidates:
        path = shutil.which(name)
        if path:
            return (path,)
    return None


def find_toolchain(extra_prefixes: Sequence[Path] = ()) -> Toolchain:
    """The compilers and ROS folders to build with, or ``ToolchainError`` naming what to install."""
    cc = _compiler("CC", ("cc", "gcc", "clang"))
    cxx = _compiler("CXX", ("c++", "g++", "clang++"))
    if cc is None or cxx is None:
        missing = "C" if cc is None else "C++"
        raise ToolchainError(
            f"no {missing} compiler found: install one (Debian/Ubuntu: `sudo apt install "
            "build-essential`; Fedora: `sudo dnf install gcc gcc-c++`) or set CC/CXX"
        )
    python_include = Path(sysconfig.get_paths()["include"])
    if not (python_include / "Python.h").is_file():
        version = f"{sys.version_info.major}.{sys.version_info.minor}"
        raise ToolchainError(
            f"Python.h not found in {python_include}: install the Python headers "
            f"(Debian/Ubuntu: `sudo apt install python{version}-dev`)"
        )
    try:
        import numpy
    except ImportError:
        raise ToolchainError("numpy is not installed: `pip install numpy`") from None
    prefixes: list[Path] = []
    for prefix in [*extra_prefixes, *ament_prefixes()]:
        if prefix not in prefixes:
            prefixes.append(prefix)
    toolchain = Toolchain(cc, cxx, tuple(prefixes), python_include, Path(numpy.get_include()))
    for package, header in (
        ("rosidl_runtime_c", "rosidl_runtime_c/message_type_support_struct.h"),
        ("fastcdr", "fastcdr/Cdr.h"),
        (
            "rosidl_typesupport_fastrtps_cpp",
            "rosidl_typesupport_fastrtps_cpp/message_type_support.h",
        ),
        ("rosidl_typesupport_introspection_c", "rosidl_typesupport_introspection_c/field_types.h"),
        ("rosidl_typesupport_c", "rosidl_typesupport_c/type_support_map.h"),
    ):
        if not any((d / header).is_file() for d in toolchain.include_dirs([package])):
            raise ToolchainError(
                f"header {header} not found under {', '.join(str(p) for p in prefixes) or '-'}: "
                f"install ROS 2 from the wheels (`pip install 'ros-jazzy-rclpy[fastrtps]'`) "
                "or source a ROS 2 Jazzy install"
            )
    return toolchain


@dataclass(frozen=True)
class SharedLibrary:
    """One shared object to build: sources, headers, libraries to link, where it looks for them."""

    output: Path
    sources: tuple[Path, ...]
    cxx: bool
    include_dirs: tuple[Path, ...]
    libraries: tuple[str, ...]
    rpath: tuple[str, ...]
    library_dirs: tuple[Path, ...] = ()
    defines: tuple[str, ...] = ()
    soname: str | None = None


def link_shared_library(toolchain: Toolchain, library: SharedLibrary) -> None:
    """Compile and link ``library`` in one compiler call; a failure is one ``ToolchainError``."""
    compiler = toolchain.cxx if library.cxx else toolchain.cc
    standard = "-std=c++17" if library.cxx else "-std=gnu11"
    command = [*compiler, standard, "-O2", "-fPIC", "-shared", "-w"]
    command += [f"-D{define}" for define in library.defines]
    command += [f"-I{d}" for d in library.include_dirs]
    command += [str(s) for s in library.sources]
    command += ["-o", str(library.output)]
    if library.soname:
        command.append(f"-Wl,-soname,{library.soname}")
    command += [f"-L{d}" for d in (*library.library_dirs, *toolchain.library_dirs())]
    command.append("-Wl,--no-as-needed")
    command += [f"-l{name}" for name in library.libraries]
    # DT_RPATH, not RUNPATH: searched before LD_LIBRARY_PATH, so a package built here wins over
    # an older build of the same package in the environment's lib/.
    command.append("-Wl,--disable-new-dtags")
    command += [f"-Wl,-rpath,{entry}" for entry in library.rpath]
    library.output.parent.mkdir(parents=True, exist_ok=True)
    result = subprocess.run(command, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        raise ToolchainError(compiler_failure(library.output.name, result.stderr))


# ``path:line[:column]: [fatal ]error: text``, and any generated file a diagnostic names.
_ERROR_LINE = re.compile(
    r"^(?P<path>[^\s:][^:]*):(?P<line>\d+):(?:\d+:)? (?:fatal )?error: (?P<text>.*)$"
)
_LOCATION = re.compile(r"(?P<path>/[^\s:'\"]+):(?P<line>\d+)")


@dataclass(frozen=True)
class _GeneratedFile:
    """A file rosidl generated in the build folder, and the interface it was generated for."""

    interface: str  # pkg/ns/Name, or pkg/ns/<file stem> when the .idl is gone
    name: str  # the file name alone: its folder is deleted when the build ends


def _generated_file(path: str) -> _GeneratedFile | None:
    """What a path in the build folder was generated from, None for any other file.

    rosidl writes ``<build>/<generator>/<pkg>/<msg|srv|action>/[detail/...]<stem>...`` and
    rosidl_adapter the .idl files at ``<build>/rosidl_adapter/<pkg>/<ns>/<Name>.idl``.
    """
    parts = Path(path).parts
    for index in range(len(parts) - 4, -1, -1):
        generator, package, namespace = parts[index : index + 3]
        if generator.startswith("rosidl_") and namespace in ("msg", "srv", "action"):
            break
    else:
        return None
    stem = parts[-1].lstrip("_").split(".")[0].split("__")[0].removesuffix("_s")
    name = stem
    adapter = Path(*parts[:index], "rosidl_adapter", package, namespace)
    for idl in sorted(adapter.glob("*.idl")):
        if _snake_case(idl.stem) == stem:
            name = idl.stem
    return _GeneratedFile(f"{package}/{namespace}/{name}", parts[-1])


def _snake_case(name: str) -> str:
    """rosidl's file stem of a type name (``HTTPStatus`` -> ``http_status``), by rosidl_pycommon's
    ``convert_camel_case_to_lower_case_underscore`` rules."""
    name = re.sub(r"(.)([A-Z][a-z]+)", r"\1_\2", name)
    return re.sub(r"([a-z0-9])([A-Z])", r"\1_\2", name).lower()


def compiler_failure(library: str, stderr: str) -> str:
    """One line from a failed compiler run: the interface whose generated code failed, where
    and why; never the path of a generated file, whose build folder is gone when this is read.
    """
    lines = stderr.splitlines()
    match = next(filter(None, map(_ERROR_LINE.match, lines)), None)
    if match is None:
        errors = [line for line in lines if "error" in line.lower()]
        first = " ".join((errors or lines or ["(no output)"])[0].split())
        return f"compiling {library} failed: {first}"
    text = " ".join(match["text"].split())
    generated = _generated_file(match["path"])
    where = f"{generated.name}:{match['line']}" if generated else f"{match['path']}:{match['line']}"
    if generated is None:
        # An error in an installed header: the generated file that included it says which type.
        for location in _LOCATION.finditer(stderr):
            generated = _generated_file(location["path"])
            if generated is not None:
                break
    if generated is None:
        return f"compiling {library} failed: {where}: error: {text}"
    return (
        f"the C/C++ code rosidl generated for {generated.interface} does not compile "
        f"({where}: {text}; building {library}): most likely a field, constant or default "
        "value of it C or C++ cannot take"
    )
