"""How rendered dict modules name each type's functions, classes and TypedDicts."""

from __future__ import annotations

from dataclasses import dataclass

from pyconnect.codegen.templating import snake_case


@dataclass(frozen=True)
class Symbols:
    """How a rendered module names the functions, classes and TypedDicts of each type.

    In a package module, the package's own types use short names and other packages' types are
    imported under qualified aliases; a self-contained (on-the-fly) module qualifies everything.
    """

    local_package: str | None

    def _qualified(self, msg_full_name: str) -> bool:
        package = msg_full_name.split("/", maxsplit=1)[0]
        return self.local_package is None or package != self.local_package

    def function(self, full_name: str) -> str:
        package, _, name = full_name.split("/")
        base = snake_case(name)
        return f"{package}__{base}" if self._qualified(full_name) else base

    def cls(self, full_name: str) -> str:
        package, namespace, name = full_name.split("/")
        return f"{package}__{namespace}__{name}" if self._qualified(full_name) else name

    def typed_dict(self, full_name: str) -> str:
        package, _, name = full_name.split("/")
        base = name.replace("_", "") + "Dict"
        return f"{package}__{base}" if self._qualified(full_name) else base
