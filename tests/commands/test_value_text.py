"""``pyconnect.commands.value_text``: fields of values and JSON lines."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from pyconnect.commands.value_text import field_of, to_json, to_yaml


@pytest.mark.parametrize(
    "data", [b"\x07\x08\x09", bytearray(b"\x07\x08\x09"), memoryview(b"\x07\x08\x09")]
)
def test_field_of_indexes_into_bytes(data: object) -> None:
    # A lossless dict holds uint8[]/byte[] (Image.data) as bytes: "data has no field '1'".
    assert field_of({"data": data}, "data.1") == 8
    with pytest.raises(KeyError) as missing:
        field_of({"data": data}, "data.3")
    assert missing.value.args[0] == "data: no item 3 of 3"


def test_to_json_writes_non_finite_floats_as_strings() -> None:
    record = {"value": {"a": float("nan"), "b": np.array([1.0, -np.inf]), "c": (np.inf,)}}

    def refuse(constant: str) -> None:
        raise ValueError(f"not JSON: {constant}")

    line = to_json(record)
    assert json.loads(line, parse_constant=refuse) == {
        "value": {"a": "nan", "b": [1.0, "-inf"], "c": ["inf"]}
    }


# Strings YAML might misread: YAML 1.1's other line breaks (NEL, LS, PS), control and format
# characters, the BOM, characters beyond U+FFFF, and text YAML would take as another scalar.
AWKWARD = [
    "a\x85b", "\x85", "a\x85", "\x85b", "a \x85 b", "a\n\x85b", "a\x85\nb",
    "a\u2028b", "\u2028", "a\u2029b", "\u2029 x", "a\r\nb", "a\rb", "a\nb", "a\n", "\n",
    "tab\there", "\x00", "\x07", "\x1b[31m", "\x7f", "\x9f", "\xa0", "\ufeffbom", "\ufffe",
    "\ud7ff", "\ue000", "\U0001f600", "\U0010ffff", " lead", "trail ", "", "~", "null", "yes",
    "true", "123", "0x10", "017", "1:30", "1e3", ".nan", "2024-01-01", "- x", "a: b", "#c", "'s'",
    '"q"', "@at", "`bt", "%p", "!tag", "*ali", "&anc", "{x}", "[y]", "?", ":", "|", ">",
    "x" * 90 + " \x85 " + "y" * 30,
]  # fmt: skip


@pytest.mark.parametrize("text", AWKWARD)
def test_to_yaml_reads_back_as_the_same_string(text: str) -> None:
    # PyYAML wrote NEL raw in a single-quoted scalar, which YAML reads as a space.
    for value in ({"data": text}, [text], text):
        assert yaml.safe_load(to_yaml(value)) == value


@pytest.mark.parametrize(
    ("text", "escaped"), [("a\x85b", "\\N"), ("a\u2028b", "\\L"), ("a\u2029b", "\\P")]
)
def test_yaml_1_1_only_line_breaks_are_escaped(text: str, escaped: str) -> None:
    # Escaped, they mean the same to YAML 1.1 and 1.2 readers (for 1.2 they are no breaks).
    assert to_yaml({"data": text}) == f'data: "a{escaped}b"\n'
