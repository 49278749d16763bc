"""PyYAML's safe loader with YAML 1.2's numbers, refusing a value that would hold itself or nest
deeper than ``MAX_VALUE_DEPTH`` (pyconnect.commands.value_input reads VALUE with it)."""

from __future__ import annotations

import math
import re
import typing

import yaml

__all__ = [
    "MAX_VALUE_DEPTH",
    "TOO_DEEP",
    "OverflowedFloat",
    "SelfReference",
    "TooDeep",
    "Yaml12Loader",
]

_FLOAT_TAG = "tag:yaml.org,2002:float"
_INT_TAG = "tag:yaml.org,2002:int"

MAX_VALUE_DEPTH = 100
"""Levels of lists and mappings a VALUE may nest (a MarkerArray's deepest field is 6 down)."""

TOO_DEEP = f"VALUE is nested too deeply: more than {MAX_VALUE_DEPTH} levels of lists and mappings"


class Yaml12Loader(yaml.SafeLoader):
    """PyYAML's safe loader with the numbers of YAML 1.2's core schema.

    Floats: ``1e-3``, ``1E-2``, ``2.5e3``, ``.inf``, ``-.inf``, ``.nan`` (YAML 1.1 wants a dot
    and a signed exponent: ``1.0e-3``). Ints: ``017`` is 17, ``0o17`` 15, ``0x1F`` 31, while
    ``0b11``, ``-0x1F`` and ``1:30`` are strings (YAML 1.1 reads octal ``017`` as 15, base 60
    ``1:30`` as 90 and binary ``0b11`` as 3). As PyYAML and Python do, ``_`` may group digits.
    A number beyond float64 (``1e400``) is an ``OverflowedFloat``: infinite, and saying so.

    An alias inside the node its anchor names (``&a [*a]``) is refused: PyYAML would build a
    list that holds itself, which every walk over the value follows until Python's recursion
    limit. So is a value nested deeper than ``MAX_VALUE_DEPTH``: how deep Python's recursion
    goes depends on the process (hypothesis, for one, raises its limit).
    """

    def __init__(self, stream: str | bytes | typing.IO[str] | typing.IO[bytes]) -> None:
        super().__init__(stream)
        self._open_anchors: set[str] = set()
        self._depth = 0

    def compose_node(self, parent: yaml.Node | None, index: int) -> yaml.Node | None:
        # Levels are lists and mappings: a scalar inside the 100th is no 101st level.
        if not isinstance(self.peek_event(), yaml.CollectionStartEvent):  # type: ignore[no-untyped-call]
            return self._compose_checked(parent, index)
        self._depth += 1
        try:
            if self._depth > MAX_VALUE_DEPTH:
                raise TooDeep(None, None, TOO_DEEP, None)
            return self._compose_checked(parent, index)
        finally:
            self._depth -= 1

    def _compose_checked(self, parent: yaml.Node | None, index: int) -> yaml.Node | None:
        event = self.peek_event()  # type: ignore[no-untyped-call]
        if isinstance(event, yaml.AliasEvent) and event.anchor in self._open_anchors:
            raise SelfReference(
                None,
                None,
                f"alias *{event.anchor} is inside the node &{event.anchor} names",
                event.start_mark,  # type: ignore[arg-type]
            )
        anchor = event.anchor if isinstance(event, yaml.CollectionStartEvent) else None
        if anchor is None:
            return super().compose_node(parent, index)
        self._open_anchors.add(anchor)
        try:
            return super().compose_node(parent, index)
        finally:
            self._open_anchors.discard(anchor)


class SelfReference(yaml.composer.ComposerError):
    """An alias inside the node its anchor names: a value that would hold itself."""


class TooDeep(yaml.composer.ComposerError):
    """More than ``MAX_VALUE_DEPTH`` levels of lists and mappings."""


class OverflowedFloat(float):
    """A float whose text is beyond float64 (``1e400``): infinite, where only ``.inf`` and
    ``-.inf`` spell infinity; ``text`` is as written, for the error that refuses it."""

    text: str

    def __new__(cls, value: float, text: str) -> OverflowedFloat:
        number = super().__new__(cls, value)
        number.text = text
        return number


# Both resolvers are replaced. A float needs a dot or an exponent: a bare 12 must stay an int.
Yaml12Loader.yaml_implicit_resolvers = {
    first: [(tag, regexp) for tag, regexp in resolvers if tag not in (_FLOAT_TAG, _INT_TAG)]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
Yaml12Loader.add_implicit_resolver(
    _FLOAT_TAG,
    re.compile(
        r"""^(?:[-+]?[0-9][0-9_]*\.[0-9_]*(?:[eE][-+]?[0-9]+)?
            |[-+]?\.[0-9][0-9_]*(?:[eE][-+]?[0-9]+)?
            |[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+
            |[-+]?\.(?:inf|Inf|INF)
            |\.(?:nan|NaN|NAN))$""",
        re.VERBOSE,
    ),
    list("-+.0123456789"),
)
_DECIMAL = re.compile(r"[-+]?[0-9][0-9_]*")
_OCTAL = re.compile(r"0o[0-7][0-7_]*")
_HEXADECIMAL = re.compile(r"0x[0-9a-fA-F][0-9a-fA-F_]*")
Yaml12Loader.add_implicit_resolver(
    _INT_TAG,
    re.compile("|".join(f"^{form.pattern}$" for form in (_DECIMAL, _OCTAL, _HEXADECIMAL))),
    list("-+0123456789"),
)


def _construct_int(loader: yaml.SafeLoader, node: yaml.Node) -> int:
    """An int of YAML 1.2: PyYAML's own would read ``017`` as octal (15)."""
    text = str(loader.construct_scalar(node))  # type: ignore[arg-type]
    digits = text.replace("_", "")
    if _DECIMAL.fullmatch(text):
        return int(digits, 10)
    if _OCTAL.fullmatch(text):
        return int(digits[2:], 8)
    if _HEXADECIMAL.fullmatch(text):
        return int(digits[2:], 16)
    raise yaml.constructor.ConstructorError(
        None, None, f"expected a YAML 1.2 int, got {text!r}", node.start_mark
    )


Yaml12Loader.add_constructor(_INT_TAG, _construct_int)


def _construct_float(loader: yaml.SafeLoader, node: yaml.Node) -> float:
    """A float as PyYAML reads it, but an OverflowedFloat where the text is no infinity: Python's
    ``float("1e400")`` is inf, and inf would be taken where a float32 field refuses 1e40."""
    number: float = loader.construct_yaml_float(node)  # type: ignore[arg-type]
    text = str(loader.construct_scalar(node))  # type: ignore[arg-type]
    if math.isinf(number) and text.lower().lstrip("+-") != ".inf":
        return OverflowedFloat(number, text)
    return number


Yaml12Loader.add_constructor(_FLOAT_TAG, _construct_float)
