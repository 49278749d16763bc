"""Names and module-level constants of a rendered wire module, and what it links from others.

A wire module holds the code of its own types and imports the code of every other type it uses
from that type's package module, named as the dict modules name them (``Symbols``): in
``sensor_msgs``, Header's decoder is ``std_msgs__header_decode``, linked from
``pyconnect_generated.std_msgs.wire_codecs`` where it is ``header_decode``.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass, field

from pyconnect.codegen.symbols import Symbols
from pyconnect.typesys.model import MessageDef
from pyconnect.typesys.primitives import NUMPY_DTYPES


@dataclass(frozen=True)
class ValueCheck:
    """An encoder's value held in a local, replaced by ``fallback`` unless exactly ``exact``."""

    local: str
    source: str
    exact: str  # bool, int or float
    fallback: str


@dataclass(frozen=True)
class RunItem:
    """One value (or padding) of a run of fixed-size values packed by one ``struct`` call."""

    segment: str  # ".stamp.sec"; "" for padding
    kind: str  # primitive name; "pad"
    size: int
    target: str = ""  # decode: local name
    source: str = ""  # encode: expression
    check: ValueCheck | None = None  # encode: how ``source`` (then a local) was checked


@dataclass
class PackageLink:
    """What a module imports from one other package's wire module."""

    package: str
    names: dict[str, str] = field(default_factory=dict)  # name there -> alias here
    functions: dict[str, str] = field(default_factory=dict)  # alias here -> function name there

    def __post_init__(self) -> None:
        # The size estimate walks nested types by name: their definitions come along.
        self.names["DEFINITIONS"] = self.table("DEFINITIONS")

    @property
    def module(self) -> str:
        return f"pyconnect_generated.{self.package}.wire_codecs"

    def table(self, name: str) -> str:
        """This module's alias of a module-wide table of the package: ``STD_MSGS__FUNCTIONS``."""
        return f"{self.package.upper()}__{name}"


class ModuleTables:
    """Constants of a module: struct formats and dtypes (named by what they are, shared), run
    labels and key sets (named by their type, so a change to one type renames nothing else),
    and the names of every type's code, local or linked."""

    def __init__(self, symbols: Symbols, local: Collection[str]) -> None:
        self.symbols = symbols
        self.local = frozenset(local)
        self.structs: dict[str, str] = {}
        self.dtypes: dict[str, str] = {}
        self.runs: dict[str, str] = {}
        self.keysets: dict[str, str] = {}
        self.links: dict[str, PackageLink] = {}
        self._runs_of: dict[str, int] = {}

    # -- per-type names, local or linked --------------------------------------------------------
    def _name(self, full_name: str, suffix: str, *, upper: bool = False) -> str:
        """This module's name for a piece of a type's code; imports it when linked."""
        here = self.symbols.function(full_name) + suffix
        if full_name in self.local:
            return here.upper() if upper else here
        package = full_name.split("/", 1)[0]
        there = Symbols(package).function(full_name) + suffix
        here, there = (here.upper(), there.upper()) if upper else (here, there)
        self._link(package).names[there] = here
        return here

    def _function(self, full_name: str, suffix: str) -> str:
        """A decoder or encoder: a closure of ``_build``, linked through the FUNCTIONS table."""
        here = self.symbols.function(full_name) + suffix
        if full_name not in self.local:
            package = full_name.split("/", 1)[0]
            link = self._link(package)
            link.names["FUNCTIONS"] = link.table("FUNCTIONS")
            link.functions[here] = Symbols(package).function(full_name) + suffix
        return here

    def _link(self, package: str) -> PackageLink:
        link = self.links.get(package)
        if link is None:
            link = self.links[package] = PackageLink(package)
        return link

    def cls(self, full_name: str) -> str:
        return self.symbols.cls(full_name)

    def view(self, full_name: str) -> str:
        """The function building a type's view from its field values."""
        return self._name(full_name, "_view")

    def decoder(self, full_name: str) -> str:
        return self._function(full_name, "_decode")

    def encoder(self, full_name: str) -> str:
        return self._function(full_name, "_encode")

    def keyset(self, msg: MessageDef) -> str:
        name = self._name(msg.full_name, "_KEYS", upper=True)
        if msg.full_name in self.local:
            keys = ", ".join(f'"{f.name}"' for f in msg.fields)
            self.keysets[name] = f"frozenset(({keys},))" if msg.fields else "frozenset()"
        return name

    # -- shared constants -------------------------------------------------------------------
    def struct(self, fmt: str) -> str:
        # "?" (bool) is the one struct code that cannot be part of a name; "T" is no code.
        return self.structs.setdefault(fmt, "_S_" + fmt.replace("?", "T"))

    def dtype(self, primitive: str) -> str:
        return self.dtypes.setdefault(NUMPY_DTYPES[primitive], f"_D_{NUMPY_DTYPES[primitive]}")

    def run_label(self, owner: MessageDef, items: Sequence[RunItem]) -> str:
        entries: list[str] = []
        end = 0
        for item in items:
            end += item.size
            if item.kind != "pad":
                entries.append(f'("{item.segment}", "{item.kind}", {end})')
        index = self._runs_of.get(owner.full_name, 0)
        self._runs_of[owner.full_name] = index + 1
        name = f"{self.symbols.function(owner.full_name).upper()}_RUN_{index}"
        self.runs[name] = "(" + ", ".join(entries) + ("," if len(entries) == 1 else "") + ")"
        return name
