"""Installed packages compiled against a dependency whose types a rebuild has since changed.

Their C code (type support, Python conversions) has the old structs of the dependency built in:
the next message holding one of its changed types corrupts memory or aborts the interpreter. Such
a dependent is found through the ament index of the prefix (``package_run_dependencies``) and
named with the command that rebuilds it; it is not rebuilt behind the user's back, since its
folder may have changed or gone since it was built.
"""

from __future__ import annotations

import json
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

from pyconnect.codegen.compile_install import InstallLayout, stamp_folder


def installed_type_hashes(layout: InstallLayout, package: str) -> dict[str, str]:
    """Type name -> RIHS01 hash of every type a package installed in ``layout`` describes."""
    hashes: dict[str, str] = {}
    for description in sorted((layout.share / package).glob("*/*.json")):
        try:
            entries = json.loads(description.read_bytes())["type_hashes"]
            hashes.update({e["type_name"]: e["hash_string"] for e in entries})
        except (OSError, ValueError, KeyError, TypeError):  # not a type description
            continue
    return hashes


def _run_dependencies(layout: InstallLayout) -> dict[str, set[str]]:
    index = layout.resource_index / "package_run_dependencies"
    if not index.is_dir():
        return {}
    return {
        entry.name: set(entry.read_text(encoding="utf-8").split(";")) - {""}
        for entry in sorted(index.iterdir())
        if entry.is_file()
    }


@dataclass(frozen=True)
class StaleDependent:
    """An installed package built against the previous types of ``changed`` (its dependencies)."""

    package: str
    changed: tuple[str, ...]
    folder: Path | None  # what it was built from, when its install says

    def advice(self, layout: InstallLayout) -> str:
        """The warning line: what is stale, why, and the command that rebuilds it."""
        folder = str(self.folder) if self.folder is not None else f"<the {self.package} folder>"
        command = f"codecgen build --compile {folder} --prefix {layout.prefix}"
        return (
            f"{self.package} in {layout.prefix} was compiled against the previous types of "
            f"{', '.join(self.changed)}, which changed: using it may abort the process; "
            f"rebuild it: {command}"
        )


def stale_dependents(
    layout: InstallLayout, changed: Collection[str], rebuilt: Collection[str]
) -> list[StaleDependent]:
    """The packages installed in ``layout`` that depend on a ``changed`` package (one whose type
    hashes a build changed) and were not ``rebuilt`` since. A package's run dependencies list
    every package whose types its types hold, through others too, so direct ones are enough."""
    stale = {
        package: sorted(dependencies & set(changed))
        for package, dependencies in _run_dependencies(layout).items()
        if package not in rebuilt and dependencies & set(changed)
    }
    return [
        StaleDependent(name, tuple(changes), stamp_folder(layout, name))
        for name, changes in sorted(stale.items())
    ]
