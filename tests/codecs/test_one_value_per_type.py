"""One value per type, whatever the source: a live message, its CDR bytes, or a bag.

The value a user gets from ``codecs.decode(msg)`` on a live message must be the value
``codecs.wire.decode`` gives for the same message's CDR and the value ``open_bag`` gives for
it, down to the types (a covariance is a list everywhere, never a list here and an ndarray
there); ndarrays compare by dtype, shape and contents.
"""

from __future__ import annotations

import importlib
import math
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rclpy.serialization import serialize_message

from pyconnect import codecs
from pyconnect.errors import CodecError
from pyconnect.record import open_bag
from pyconnect.record.mcap_recorder import McapRecorder
from tests.strategies import default_packages, message_dicts

_, TYPES = default_packages()
MESSAGE_TYPES = sorted(name for name in TYPES.messages if name.split("/")[1] == "msg")
_SETTINGS = settings(max_examples=3, deadline=None, database=None,
                     suppress_health_check=list(HealthCheck))  # fmt: skip


def message_class(full_name: str) -> Any:
    package, namespace, name = full_name.split("/")
    return getattr(importlib.import_module(f"{package}.{namespace}"), name)


def difference(left: Any, right: Any, path: str = "") -> str | None:
    """Where two values differ, in type or in value; None when they are the same."""
    if type(left) is not type(right):
        return f"{path or 'value'}: {type(left).__name__} vs {type(right).__name__}"
    if isinstance(left, np.ndarray):
        same = (
            left.dtype == right.dtype
            and left.shape == right.shape
            and left.tobytes() == np.ascontiguousarray(right).tobytes()
            if left.dtype.kind != "V"
            else left.tobytes() == right.tobytes()
        )
        return (
            None
            if same
            else f"{path}: arrays differ ({left.dtype}{left.shape} vs {right.dtype}{right.shape})"
        )
    if isinstance(left, dict):
        if left.keys() != right.keys():
            return f"{path}: keys {sorted(left)} vs {sorted(right)}"
        for key in left:
            found = difference(left[key], right[key], f"{path}.{key}")
            if found:
                return found
        return None
    if isinstance(left, list | tuple):
        if len(left) != len(right):
            return f"{path}: length {len(left)} vs {len(right)}"
        for index, (a, b) in enumerate(zip(left, right, strict=True)):
            found = difference(a, b, f"{path}[{index}]")
            if found:
                return found
        return None
    if isinstance(left, float):
        same = (math.isnan(left) and math.isnan(right)) or struct.pack("<d", left) == struct.pack(
            "<d", right
        )
        return None if same else f"{path}: {left!r} vs {right!r}"
    if hasattr(left, "__dataclass_fields__"):
        return difference(
            {k: getattr(left, k) for k in left.__dataclass_fields__},
            {k: getattr(right, k) for k in right.__dataclass_fields__},
            path,
        )
    return None if left == right else f"{path}: {left!r} vs {right!r}"


@pytest.mark.parametrize("full_name", MESSAGE_TYPES)
@_SETTINGS
@given(data=st.data())
def test_live_and_wire_values_are_the_same(full_name: str, data: st.DataObject) -> None:
    msg = codecs.from_dict(data.draw(message_dicts(TYPES.get(full_name), TYPES)), full_name)
    try:
        live = ("value", codecs.decode(msg))
    except CodecError as error:  # a natural codec may refuse a value: both must
        live = ("error", type(error).__name__)
    try:
        wired = ("value", codecs.wire.decode(serialize_message(msg), full_name))
    except CodecError as error:
        wired = ("error", type(error).__name__)
    assert difference(live, wired) is None, difference(live, wired)


def test_bag_values_are_the_live_values(tmp_path: Path) -> None:
    messages = {}
    bag = tmp_path / "every_type"
    with McapRecorder(bag) as recorder:
        for index, full_name in enumerate(MESSAGE_TYPES):
            topic = f"/t{index}"
            msg = message_class(full_name)()
            recorder.add_topic(topic, full_name)
            recorder.write(topic, serialize_message(msg), log_time_ns=index + 1)
            messages[topic] = msg
    decodable = set()
    for topic, msg in messages.items():
        try:
            codecs.decode(msg)
        except CodecError:  # a default Image has no encoding: refused live and from bags
            continue
        decodable.add(topic)
    seen = set()
    with open_bag(bag) as reader:
        for topic, _, value in reader:
            seen.add(topic)
            live = codecs.decode(messages[topic])
            assert difference(live, value) is None, (topic, difference(live, value))
    assert seen == decodable
    assert len(seen) >= len(MESSAGE_TYPES) - 2


def test_imu_covariance_is_a_list_from_every_source(tmp_path: Path) -> None:
    from sensor_msgs.msg import Imu

    msg = Imu()
    msg.orientation_covariance[4] = 0.5
    cdr = serialize_message(msg)
    with McapRecorder(tmp_path / "imu") as recorder:
        recorder.add_topic("/imu", "sensor_msgs/msg/Imu")
        recorder.write("/imu", cdr, log_time_ns=1)
    with open_bag(tmp_path / "imu") as reader:
        ((_, _, from_bag),) = list(reader)
    for value in (codecs.decode(msg), codecs.wire.decode(cdr, "sensor_msgs/Imu"), from_bag):
        assert value["orientation_covariance"] == [0.0] * 4 + [0.5] + [0.0] * 4
        assert type(value["orientation_covariance"]) is list
