"""JointState ↔ dict keyed by joint name."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st
from sensor_msgs.msg import JointState

from pyconnect import codecs
from pyconnect.errors import DecodeError, EncodeError
from tests.codecs.natural.helpers import EXAMPLES, same, wire_view
from tests.strategies import SENDABLE_CHARACTERS

CODEC = codecs.lookup("sensor_msgs/msg/JointState")


@st.composite
def joint_dicts(draw: st.DrawFn) -> dict[str, Any]:
    # No NUL nor lone surrogate: a joint name with one is refused on encode
    # (tests/codecs/test_nul_strings.py, tests/hardening/test_malformed_values.py).
    name = st.text(SENDABLE_CHARACTERS, min_size=1, max_size=8)
    names = draw(st.lists(name, unique=True, max_size=6))
    keys = draw(st.sets(st.sampled_from(["position", "velocity", "effort"]), min_size=1))
    ordered = [k for k in ("position", "velocity", "effort") if k in keys]
    return {n: {k: draw(st.floats()) for k in ordered} for n in names}


@EXAMPLES
@given(joint_dicts())
def test_round_trip(joints: dict[str, Any]) -> None:
    msg = CODEC.encode(joints)
    assert same(CODEC.decode(msg), joints) or not joints
    assert same(CODEC.decode(wire_view(msg)), CODEC.decode(msg))
    rebuilt = codecs.from_dict(CODEC.to_fields(joints), JointState)
    assert same(CODEC.decode(rebuilt), CODEC.decode(msg))


def test_positions_shorthand_and_partial_arrays() -> None:
    msg = CODEC.encode({"shoulder": 0.1, "elbow": 2})
    assert list(msg.name) == ["shoulder", "elbow"] and list(msg.velocity) == []
    assert CODEC.decode(msg) == {"shoulder": {"position": 0.1}, "elbow": {"position": 2.0}}
    msg = JointState(name=["a", "b"], position=[1.0, 2.0], effort=[3.0, 4.0])
    assert CODEC.decode(msg) == {
        "a": {"position": 1.0, "effort": 3.0},
        "b": {"position": 2.0, "effort": 4.0},
    }
    assert CODEC.decode(JointState(name=["a"])) == {"a": {}}


def test_unequal_arrays_are_named() -> None:
    msg = JointState(name=["a", "b", "c"], position=[1.0, 2.0, 3.0], velocity=[0.0, 1.0])
    with pytest.raises(DecodeError) as error:
        CODEC.decode(msg)
    assert str(error.value) == "JointState.velocity: has 2 values but JointState.name has 3"


def test_a_joint_named_twice() -> None:
    with pytest.raises(DecodeError) as error:
        CODEC.decode(JointState(name=["a", "b", "a"], position=[1.0, 2.0, 3.0]))
    assert str(error.value) == "JointState.name: joint 'a' appears more than once"


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ([("a", 1.0)], "JointState: expected a dict of joint name -> float or dict, got list"),
        ({"a": "1.0"}, "JointState['a']: expected float or dict, got str"),
        ({"a": {"position": "x"}}, "JointState['a'].position: expected float, got str"),
        (
            {"a": {"speed": 1.0}},
            ("JointState['a']: unknown key 'speed' (keys: position, velocity, effort)"),
        ),
        (
            {"a": {"position": 1.0}, "b": {"position": 1.0, "velocity": 0.0}},
            (
                "JointState['b']: expected keys position like the joints before, got position, "
                "velocity"
            ),
        ),
        ({1: 1.0}, "JointState.name: expected str, got int"),
        # bools are refused wherever numbers go, on the fast path too (array('d') takes them)
        ({"a": True}, "JointState['a']: expected float or dict, got bool"),
        ({"a": 1.0, "b": False}, "JointState['b']: expected float or dict, got bool"),
        ({"a": {"position": 1.0, "velocity": True}}, "JointState['a'].velocity: expected float, got bool"),
        ({"a": 10**400}, "JointState['a']: expected float, got an int too large for float64"),
        ({"a": {"effort": -(10**400)}}, "JointState['a'].effort: expected float, got an int too large for float64"),
    ],
)
def test_bad_values(value: Any, message: str) -> None:
    with pytest.raises(EncodeError) as error:
        CODEC.encode(value)
    assert str(error.value) == message
