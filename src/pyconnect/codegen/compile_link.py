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
from dataclasses import dataclass
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
GENERATOR_C = "rosidl_generator_c"
TYPESUPPORT_C = "rosidl_typesupport_c"
GENERATOR_PY = "rosidl_generator_py"


def library_name(package: str, generator: str) -> str:
    return f"{package}__{generator}"


def extension_filename(package: str, typesupport: str) -> str:
    return f"{package}_s__{typesupport}{sysconfig.get_config_var('EXT_SUFFIX')}"


@dataclass(frozen=True)
class Recipe:
    """How one library of a package is built; every one has this shape.

    It links the package's own libraries of ``own``, the dependencies' libraries of ``linked``,
    then the ROS libraries ``system``; headers come from the generators ``headers`` and the ROS
    packages ``runtime`` (plus the dependencies' and the common runtime's).
    """

    generator: str
    pattern: str  # its sources in the generator's output
    headers: tuple[str, ...]
    own: tuple[str, ...]
    linked: tuple[str, ...]
    system: tuple[str, ...]
    runtime: tuple[str, ...] = ()
    define: str = ""  # the BUILDING_DLL macro, named after the package
    python: bool = False  # needs Python's and numpy's headers


_RUNTIME_C = ("rosidl_runtime_c", "rcutils")
_FASTRTPS_C = "rosidl_typesupport_fastrtps_c"
_INTROSPECTION_C = "rosidl_typesupport_introspection_c"
# Stages: the libraries of one stage do not need each other and build side by side; every later
# stage links the earlier ones.
STAGES: tuple[tuple[Recipe, ...], ...] = (
    (
        Recipe(
            GENERATOR_C, "*.c", headers=(GENERATOR_C,), own=(), linked=(GENERATOR_C,),
            system=_RUNTIME_C,
            runtime=("rosidl_runtime_c", "rosidl_typesupport_interface", "rcutils"),
            define="ROSIDL_GENERATOR_C_BUILDING_DLL",
        ),
    ),
    (
        Recipe(
            _FASTRTPS_C, "*.cpp", headers=(_FASTRTPS_C, GENERATOR_C), own=(GENERATOR_C,),
            linked=(_FASTRTPS_C, GENERATOR_C),
            system=(_FASTRTPS_C, "rosidl_typesupport_fastrtps_cpp", "rosidl_runtime_c", "fastcdr",
                    "rcutils"),
            runtime=("fastcdr", "rosidl_runtime_c", "rosidl_runtime_cpp",
                     "rosidl_typesupport_interface", "rosidl_typesupport_fastrtps_cpp",
                     _FASTRTPS_C, "rcutils"),
            define="ROSIDL_TYPESUPPORT_FASTRTPS_C_BUILDING_DLL",
        ),
        Recipe(
            _INTROSPECTION_C, "*.c", headers=(_INTROSPECTION_C, GENERATOR_C), own=(GENERATOR_C,),
            linked=(_INTROSPECTION_C, GENERATOR_C), system=(_INTROSPECTION_C, *_RUNTIME_C),
            runtime=("rosidl_runtime_c", "rosidl_typesupport_interface", _INTROSPECTION_C,
                     "rcutils"),
            define="ROSIDL_TYPESUPPORT_INTROSPECTION_C_BUILDING_DLL",
        ),
    ),
    # The dispatch library dlopen()s the typesupport libraries by bare name; linking them here
    # loads them first, so that lookup finds them even when lib/ is not on LD_LIBRARY_PATH.
    (
        Recipe(
            TYPESUPPORT_C, "*.cpp", headers=(GENERATOR_C,), own=(GENERATOR_C, *C_TYPESUPPORTS),
            linked=(TYPESUPPORT_C, GENERATOR_C), system=(TYPESUPPORT_C, *_RUNTIME_C),
            runtime=("rosidl_runtime_c", "rosidl_typesupport_interface", TYPESUPPORT_C,
                     "rcutils"),
            define="ROSIDL_GENERATOR_C_BUILDING_DLL",
        ),
    ),
    (
        Recipe(
            GENERATOR_PY, "_*_s.c", headers=(GENERATOR_C, GENERATOR_PY),
            own=(GENERATOR_C, TYPESUPPORT_C), linked=(GENERATOR_PY, GENERATOR_C),
            system=_RUNTIME_C, python=True,
        ),
    ),
)  # fmt: skip


def extension_recipe(typesupport: str) -> Recipe:
    """The Python extension module of one typesupport (its one source is named, not globbed)."""
    return Recipe(
        typesupport, "", headers=(GENERATOR_C, GENERATOR_PY),
        own=(GENERATOR_PY, typesupport, TYPESUPPORT_C, GENERATOR_C),
        linked=(GENERATOR_PY, TYPESUPPORT_C, GENERATOR_C), system=(TYPESUPPORT_C, *_RUNTIME_C),
        python=True,
    )  # fmt: skip


@dataclass(frozen=True)
class _Planner:
    """Turns recipes into the shared objects of one package."""

    sources: GeneratedSources
    dependencies: Sequence[str]
    toolchain: Toolchain
    lib_dir: Path
    python_dir: Path
    lib_rpath_from_python: str

    def library(self, recipe: Recipe) -> SharedLibrary:
        package = self.sources.package
        output = self.lib_dir / f"lib{library_name(package, recipe.generator)}.so"
        rpath: tuple[str, ...] = ("$ORIGIN",)
        sources = self.sources.files(recipe.generator, recipe.pattern)
        if not recipe.pattern:  # an extension module
            output = self.python_dir / extension_filename(package, recipe.generator)
            rpath = (f"$ORIGIN/{self.lib_rpath_from_python}",)
            py_out = self.sources.output(GENERATOR_PY)
            sources = (py_out / f"_{package}_s.ep.{recipe.generator}.c",)
        return SharedLibrary(
            output=output,
            sources=sources,
            cxx=recipe.pattern.endswith(".cpp"),
            include_dirs=self.include_dirs(recipe),
            libraries=(
                *(library_name(package, g) for g in recipe.own),
                *(library_name(dep, g) for g in recipe.linked for dep in self.dependencies),
                *recipe.system,
            ),
            rpath=(*rpath, *(str(d) for d in self.toolchain.library_dirs())),
            library_dirs=(self.lib_dir,),
            defines=(f"{recipe.define}_{package}",) if recipe.define else (),
            soname=output.name if recipe.pattern else None,
        )

    def include_dirs(self, recipe: Recipe) -> tuple[Path, ...]:
        own = tuple(self.sources.root(g) for g in recipe.headers)
        packages = dict.fromkeys([*self.dependencies, *recipe.runtime, *RUNTIME_PACKAGES])
        found = (*own, *self.toolchain.include_dirs(packages))
        if recipe.python:
            return (*found, self.toolchain.python_include, self.toolchain.numpy_include)
        return found


def plan_libraries(
    *,
    sources: GeneratedSources,
    dependencies: Sequence[str],
    toolchain: Toolchain,
    lib_dir: Path,
    python_dir: Path,
    lib_rpath_from_python: str,
) -> list[list[SharedLibrary]]:
    """The shared objects of ``sources.package``, stage by stage (a stage links the earlier)."""
    planner = _Planner(sources, dependencies, toolchain, lib_dir, python_dir,
                       lib_rpath_from_python)  # fmt: skip
    stages = [[planner.library(recipe) for recipe in stage] for stage in STAGES]
    stages.append([planner.library(extension_recipe(ts)) for ts in PY_TYPESUPPORTS])
    return stages


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
    built: list[Path] = []
    stages = plan_libraries(sources=sources, dependencies=dependencies, toolchain=toolchain,
                            lib_dir=lib_dir, python_dir=python_dir,
                            lib_rpath_from_python=lib_rpath_from_python)  # fmt: skip
    for stage in stages:
        workers = max(1, min(len(stage), os.cpu_count() or 1))
        with ThreadPoolExecutor(max_workers=workers) as pool:
            for _ in pool.map(lambda library: link_shared_library(toolchain, library), stage):
                pass
        built.extend(library.output for library in stage)
    return built


def relative_rpath(python_dir: Path, lib_dir: Path) -> str:
    """The path from the installed Python package to the installed ``lib/`` (for $ORIGIN)."""
    return os.path.relpath(lib_dir, python_dir)
