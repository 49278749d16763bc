"""``pyconnect.commands.value_text``: fields of values and JSON lines."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pyconnect.commands.value_text import field_of, to_json


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
