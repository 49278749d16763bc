"""dict2str/str2dict: JSON round trips, never code execution."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyconnect.errors import DecodeError, EncodeError
from pyconnect.utils import dict2str, str2dict

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(),
    lambda children: st.lists(children) | st.dictionaries(st.text(), children),
    max_leaves=20,
)


@settings(max_examples=60)
@given(st.dictionaries(st.text(), json_values))
def test_round_trip(data: dict[str, object]) -> None:
    assert str2dict(dict2str(data)) == data


def test_tuples_and_numpy_become_lists() -> None:
    text = dict2str({"cmd": "forward", "speed": np.float32(0.5), "pose": (1, 2), "a": np.arange(3)})
    assert str2dict(text) == {"cmd": "forward", "speed": 0.5, "pose": [1, 2], "a": [0, 1, 2]}


def test_unserialisable_value_raises() -> None:
    with pytest.raises(EncodeError) as caught:
        dict2str({"f": object()})
    assert str(caught.value) == "dict2str: expected JSON data, got object"


def test_code_is_not_executed() -> None:
    with pytest.raises(DecodeError) as caught:
        str2dict("__import__('os').system('true')")
    assert str(caught.value).startswith("str2dict: not JSON: Expecting value")


def test_non_string_rejected() -> None:
    with pytest.raises(DecodeError) as caught:
        str2dict(3)  # type: ignore[arg-type]
    assert str(caught.value) == "str2dict: expected str, got int"
