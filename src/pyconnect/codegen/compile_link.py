"""Compile the generated C/C++ sources into the libraries and extension modules colcon installs.

Per package ``P`` (names as rosidl's CMake gives them): ``libP__rosidl_generator_c.so``,
``libP__rosidl_typesupport_fastrtps_c.so``, ``libP__rosidl_typesupport_introspection_c.so``,
``libP__rosidl_typesupport_c.so``, ``libP__rosidl_generator_py.so`` in ``lib/``, and the Python
extension modules ``P_s__<typesupport>`` inside the Python package. Every object carries a
run path to the install's ``lib/`` (relative, so the prefix can be moved as a whole) and to the
ROS libraries it was built against, so importing needs no ``LD_LIBRARY_PATH``.
"""

from __future__ import annotations

import os
import sysconfig
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from pyconnect.codegen.compile_generate import C_TYPESUPPORTS, PY_TYPESUPPORTS, GeneratedSources
from pyconnect.codegen.compile_toolchain import (
    RUNTIME_PACKAGES,
    SharedLibrary,
    Toolchain,
    link_shared_library,
)

GENERATOR_LIBRARIES = (
    "rosidl_generator_c", *C_TYPESUPPORTS, "rosidl_typesupport_c", "rosidl_generator_py",
)  # fmt: skip


def library_name(package: str, generator: str) -> str:
    return f"{package}__{generator}"


def extension_filename(package: str, typesupport: str) -> str:
    return f"{package}_s__{typesupport}{sysconfig.get_config_var('EXT_SUFFIX')}"


def build_libraries(
    *,
    sources: GeneratedSources,
    dependencies: Sequence[str],
    toolchain: Toolchain,
    lib_dir: Path,
    python_dir: Path,
    lib_rpath_from_python: str,
) -> list[Path]:
    """Compile everything for ``sources.package`` into ``lib_dir`` and ``python_dir``."""
    package = sources.package
    ros_lib_dirs = tuple(str(d) for d in toolchain.library_dirs())

    def includes(*generators: str, runtime: Sequence[str]) -> tuple[Path, ...]:
        own = tuple(sources.root(g) for g in generators)
        packages = [*dependencies, *runtime, *RUNTIME_PACKAGES]
        return own + tuple(toolchain.include_dirs(dict.fromkeys(packages)))

    def deps(generator: str) -> tuple[str, ...]:
        return tuple(library_name(dep, generator) for dep in dependencies)

    built: list[Path] = []
    stage: list[SharedLibrary] = []

    def link(generator: str, library: SharedLibrary) -> None:
        stage.append(library)

    def flush() -> None:
        """Build the queued libraries (they do not need each other) side by side."""
        with ThreadPoolExecutor(max_workers=max(1, min(len(stage), os.cpu_count() or 1))) as pool:
            for _ in pool.map(lambda library: link_shared_library(toolchain, library), stage):
                pass
        built.extend(library.output for library in stage)
        stage.clear()

    def lib(generator: str) -> Path:
        return lib_dir / f"lib{library_name(package, generator)}.so"

    own_c = library_name(package, "rosidl_generator_c")
    common_rpath = ("$ORIGIN", *ros_lib_dirs)
    link(
        "rosidl_generator_c",
        SharedLibrary(
            output=lib("rosidl_generator_c"),
            sources=sources.files("rosidl_generator_c", "*.c"),
            cxx=False,
            include_dirs=includes(
                "rosidl_generator_c",
                runtime=("rosidl_runtime_c", "rosidl_typesupport_interface", "rcutils"),
            ),
            libraries=(*deps("rosidl_generator_c"), "rosidl_runtime_c", "rcutils"),
            rpath=common_rpath,
            library_dirs=(lib_dir,),
            defines=(f"ROSIDL_GENERATOR_C_BUILDING_DLL_{package}",),
            soname=lib("rosidl_generator_c").name,
        ),
    )
    flush()  # everything else links the C library
    link(
        "rosidl_typesupport_fastrtps_c",
        SharedLibrary(
            output=lib("rosidl_typesupport_fastrtps_c"),
            sources=sources.files("rosidl_typesupport_fastrtps_c", "*.cpp"),
            cxx=True,
            include_dirs=includes(
                "rosidl_typesupport_fastrtps_c",
                "rosidl_generator_c",
                runtime=(
                    "fastcdr",
                    "rosidl_runtime_c",
                    "rosidl_runtime_cpp",
                    "rosidl_typesupport_interface",
                    "rosidl_typesupport_fastrtps_cpp",
                    "rosidl_typesupport_fastrtps_c",
                    "rcutils",
                ),
            ),
            libraries=(
                own_c,
                *deps("rosidl_typesupport_fastrtps_c"),
                *deps("rosidl_generator_c"),
                "rosidl_typesupport_fastrtps_c",
                "rosidl_typesupport_fastrtps_cpp",
                "rosidl_runtime_c",
                "fastcdr",
                "rcutils",
            ),
            rpath=common_rpath,
            library_dirs=(lib_dir,),
            defines=(f"ROSIDL_TYPESUPPORT_FASTRTPS_C_BUILDING_DLL_{package}",),
            soname=lib("rosidl_typesupport_fastrtps_c").name,
        ),
    )
    link(
        "rosidl_typesupport_introspection_c",
        SharedLibrary(
            output=lib("rosidl_typesupport_introspection_c"),
            sources=sources.files("rosidl_typesupport_introspection_c", "*.c"),
            cxx=False,
            include_dirs=includes(
                "rosidl_typesupport_introspection_c",
                "rosidl_generator_c",
                runtime=(
                    "rosidl_runtime_c",
                    "rosidl_typesupport_interface",
                    "rosidl_typesupport_introspection_c",
                    "rcutils",
                ),
            ),
            libraries=(
                own_c,
                *deps("rosidl_typesupport_introspection_c"),
                *deps("rosidl_generator_c"),
                "rosidl_typesupport_introspection_c",
                "rosidl_runtime_c",
                "rcutils",
            ),
            rpath=common_rpath,
            library_dirs=(lib_dir,),
            defines=(f"ROSIDL_TYPESUPPORT_INTROSPECTION_C_BUILDING_DLL_{package}",),
            soname=lib("rosidl_typesupport_introspection_c").name,
        ),
    )
    flush()
    # The dispatch library dlopen()s the typesupport libraries by bare name; linking them here
    # loads them first, so that lookup finds them even when lib/ is not on LD_LIBRARY_PATH.
    link(
        "rosidl_typesupport_c",
        SharedLibrary(
            output=lib("rosidl_typesupport_c"),
            sources=sources.files("rosidl_typesupport_c", "*.cpp"),
            cxx=True,
            include_dirs=includes(
                "rosidl_generator_c",
                runtime=(
                    "rosidl_runtime_c",
                    "rosidl_typesupport_interface",
                    "rosidl_typesupport_c",
                    "rcutils",
                ),
            ),
            libraries=(
                own_c,
                *(library_name(package, ts) for ts in C_TYPESUPPORTS),
                *deps("rosidl_typesupport_c"),
                *deps("rosidl_generator_c"),
                "rosidl_typesupport_c",
                "rosidl_runtime_c",
                "rcutils",
            ),
            rpath=common_rpath,
            library_dirs=(lib_dir,),
            defines=(f"ROSIDL_GENERATOR_C_BUILDING_DLL_{package}",),
            soname=lib("rosidl_typesupport_c").name,
        ),
    )
    flush()
    py_includes = (
        *includes("rosidl_generator_c", "rosidl_generator_py", runtime=()),
        toolchain.python_include,
        toolchain.numpy_include,
    )
    link(
        "rosidl_generator_py",
        SharedLibrary(
            output=lib("rosidl_generator_py"),
            sources=sources.files("rosidl_generator_py", "_*_s.c"),
            cxx=False,
            include_dirs=py_includes,
            libraries=(
                own_c,
                library_name(package, "rosidl_typesupport_c"),
                *deps("rosidl_generator_py"),
                *deps("rosidl_generator_c"),
                "rosidl_runtime_c",
                "rcutils",
            ),
            rpath=common_rpath,
            library_dirs=(lib_dir,),
            soname=lib("rosidl_generator_py").name,
        ),
    )
    flush()
    py_out = sources.output("rosidl_generator_py")
    for typesupport in PY_TYPESUPPORTS:
        link(
            typesupport,
            SharedLibrary(
                output=python_dir / extension_filename(package, typesupport),
                sources=(py_out / f"_{package}_s.ep.{typesupport}.c",),
                cxx=False,
                include_dirs=py_includes,
                libraries=(
                    library_name(package, "rosidl_generator_py"),
                    library_name(package, typesupport),
                    library_name(package, "rosidl_typesupport_c"),
                    own_c,
                    *deps("rosidl_generator_py"),
                    *deps("rosidl_typesupport_c"),
                    *deps("rosidl_generator_c"),
                    "rosidl_typesupport_c",
                    "rosidl_runtime_c",
                    "rcutils",
                ),
                rpath=(f"$ORIGIN/{lib_rpath_from_python}", *ros_lib_dirs),
                library_dirs=(lib_dir,),
            ),
        )
    flush()
    return built


def relative_rpath(python_dir: Path, lib_dir: Path) -> str:
    """The path from the installed Python package to the installed ``lib/`` (for $ORIGIN)."""
    return os.path.relpath(lib_dir, python_dir)
