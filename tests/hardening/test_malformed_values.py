"""Malformed dicts and values for every generated type: only EncodeError naming the path.

A valid lossless dict gets one field spoiled (wrong type, NaN/inf or floats where ints go,
huge ints, deep nesting, a cyclic dict, numpy arrays of the wrong dtype or shape); both
encoders (the generated dict codec to an rclpy message, and the CDR wire codec) must raise
``EncodeError`` whose text starts with the type's name. Arrays that are only laid out
unusually (non-contiguous, read-only, byte-swapped) must encode to exactly the same message.
"""

from __future__ import annotations

import importlib
import math
import pkgutil
from typing import Any

import numpy as np
import pyconnect_generated
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rclpy.serialization import serialize_message

from pyconnect import codecs
from pyconnect.codecs import wire
from pyconnect.errors import EncodeError
from pyconnect.typesys.model import FieldType, MessageDef
from tests.strategies import all_types, message_dicts

TYPES = all_types()


def _dict_codecs() -> dict[str, tuple[Any, ...]]:
    entries: dict[str, tuple[Any, ...]] = {}
    for info in pkgutil.iter_modules(pyconnect_generated.__path__):
        module = importlib.import_module(f"pyconnect_generated.{info.name}.dict_codecs")
        entries.update(module.DICT_CODECS)
    return entries


CODECS = _dict_codecs()
NAMES = sorted(name for name in CODECS if TYPES.get(name).fields)
_SETTINGS = settings(max_examples=150, deadline=None, database=None,
                     suppress_health_check=list(HealthCheck))  # fmt: skip


def _deep(levels: int) -> Any:
    value: Any = 1.0
    for _ in range(levels):
        value = [value]
    return value


def _cyclic() -> dict[str, Any]:
    loop: dict[str, Any] = {}
    loop["self"] = loop
    return loop


def bad_single(ftype: FieldType) -> list[Any]:
    """Values that no single field of this element type may take."""
    element = ftype.element
    common: list[Any] = [None, object(), _cyclic(), _deep(500), {"nested": 1}, complex(1, 1)]
    if element.kind == "message":
        return [*common, 5, "text", [1], _cyclic(), {"no_such_field": 1}]
    if element.kind in ("string", "wstring"):
        values = [*common, 5, b"bytes", ["a"], 1.5]
        if element.string_bound is not None:
            values.append("x" * (element.string_bound + 1))
        return values
    if element.name == "bool":
        return [*common, "yes", [True], 1.5, np.array([True, False])]
    if element.name in ("float32", "float64"):
        values = [*common, "1.0", [1.0], b"\x00", 10**400, np.array([1.0, 2.0])]
        if element.name == "float32":
            values.append(1e300)
        return values
    # integers (and byte/char)
    return [*common, "1", 1.5, math.nan, math.inf, -math.inf, 2**64, -(2**64) - 1,
            np.float64(2.0), [1], np.array([1, 2])]  # fmt: skip


def bad_container(ftype: FieldType) -> list[Any]:
    """Values no array/sequence field of this element type may take."""
    element = ftype.element
    values: list[Any] = [None, 5, object(), _cyclic(), {"a": 1}, np.zeros((2, 2)),
                         np.array([1 + 2j]), np.array([object()])]  # fmt: skip
    if element.kind not in ("string", "wstring"):
        values.append(np.array(["a", "b"]))
    if element.kind != "message" and not element.is_bytes_like:
        values.append("abc")  # a str is iterable, but not a list of values
    if ftype.size is not None:
        values.append([_example(ftype)] * (ftype.size + 1))
    if element.is_integer and not element.is_bytes_like:
        values += [[1.5], [math.nan], [2**64], np.array([1.5, 2.5])]
    if element.is_float:
        values += [["1.0"], [None], [10**400]]
    return values


def _example(ftype: FieldType) -> Any:
    element = ftype.element
    if element.kind == "message":
        return {}
    if element.kind in ("string", "wstring"):
        return ""
    if element.name == "bool":
        return False
    return 0.0 if element.is_float else 0


def encode_both(full_name: str, value: Any) -> list[Any]:
    """The two encoders' outputs (rclpy message, wire CDR), or their EncodeErrors.

    Messages are compared as messages: Fast CDR leaves padding bytes uninitialised."""
    from_dict = CODECS[full_name][2]
    results: list[Any] = []
    for encode in (lambda: _serialisable(from_dict(value)),
                   lambda: wire.from_dict(value, full_name)):  # fmt: skip
        try:
            results.append(encode())
        except EncodeError as error:
            results.append(error)
    return results


def _serialisable(msg: Any) -> Any:
    serialize_message(msg)  # what publishing does: it must not raise either
    return msg


def fields_of(msg: MessageDef) -> list[tuple[str, FieldType]]:
    return [(field.name, field.type) for field in msg.fields]


@pytest.mark.parametrize("chunk", range(4))
@_SETTINGS
@given(data=st.data())
def test_spoiled_field_raises_encode_error_with_path(chunk: int, data: st.DataObject) -> None:
    names = NAMES[chunk::4]
    full_name = data.draw(st.sampled_from(names))
    msg = TYPES.get(full_name)
    value = data.draw(message_dicts(msg, TYPES))
    # Walk down into nested messages now and then, so deep paths are spoiled too.
    target, path = value, full_name.rsplit("/", 1)[-1]
    current = msg
    while True:
        name, ftype = data.draw(st.sampled_from(fields_of(current)))
        if ftype.is_single and ftype.element.kind == "message":
            inner = TYPES.get(ftype.element.name)
            if inner.fields and data.draw(st.booleans()):
                target, current, path = target[name], inner, f"{path}.{name}"
                continue
        break
    bad = bad_single(ftype) if ftype.is_single else bad_container(ftype)
    target[name] = data.draw(st.sampled_from(bad))
    short = full_name.rsplit("/", 1)[-1]
    for outcome in encode_both(full_name, value):
        assert isinstance(outcome, EncodeError), (path, name, target[name])
        assert str(outcome).startswith(short), str(outcome)


NUMERIC = [
    (name, field.name, field.type)
    for name in NAMES
    for field in TYPES.get(name).fields
    if not field.type.is_single and field.type.element.is_primitive
    and field.type.element.name not in ("bool",)
]  # fmt: skip


@pytest.mark.parametrize(("full_name", "field", "ftype"), NUMERIC[::3],
                         ids=[f"{n}.{f}" for n, f, _ in NUMERIC[::3]])  # fmt: skip
def test_unusual_array_layouts_encode_exactly(full_name: str, field: str, ftype: FieldType) -> None:
    count = ftype.size if ftype.is_array else min(ftype.size or 3, 3)
    if not count:
        return
    dtype = np.dtype(_NUMPY[ftype.element.name])
    base = np.arange(2 * count, dtype=dtype)[::2]  # non-contiguous
    assert not base.flags.c_contiguous
    expected = encode_both(full_name, {field: base.tolist() if dtype != np.uint8
                                       else bytes(base.tolist())})  # fmt: skip
    readonly = base.copy()
    readonly.flags.writeable = False
    swapped = base.astype(dtype.newbyteorder(">" if dtype.byteorder != ">" else "<"))
    for layout in (base, readonly, swapped):
        assert encode_both(full_name, {field: layout}) == expected, layout


_NUMPY = {"byte": "uint8", "char": "uint8", "uint8": "uint8", "int8": "int8",
          "int16": "int16", "uint16": "uint16", "int32": "int32", "uint32": "uint32",
          "int64": "int64", "uint64": "uint64", "float32": "float32", "float64": "float64"}  # fmt: skip


@pytest.mark.parametrize(
    ("type_name", "value", "path"),
    [
        ("std_msgs/msg/String", {"data": "\ud800"}, "String.data"),
        ("std_msgs/msg/Header", {"frame_id": "caf\u00e9\udc80"}, "Header.frame_id"),
        ("test_msgs/msg/UnboundedSequences", {"string_values": ["ok", "\udc80"]},
         "UnboundedSequences.string_values[1]"),
        ("test_msgs/msg/BoundedSequences", {"string_values": ["\ud800"]},
         "BoundedSequences.string_values[0]"),
    ],
)  # fmt: skip
def test_unencodable_strings_are_refused_on_both_paths(
    type_name: str, value: dict[str, object], path: str
) -> None:
    # The class path handed such strings to rclpy, whose serialisation then raised a bare
    # UnicodeEncodeError at publish; both paths now refuse them with the same words.
    expected = f"{path}: cannot encode as UTF-8 (surrogates not allowed)"
    with pytest.raises(EncodeError) as caught:
        wire.from_dict(value, type_name)
    assert str(caught.value) == expected
    with pytest.raises(EncodeError) as caught:
        codecs.from_dict(value, type_name)
    assert str(caught.value) == expected


def test_a_lone_surrogate_is_refused_by_the_string_codec() -> None:
    with pytest.raises(EncodeError) as caught:
        codecs.encode("a\udc80", "std_msgs/msg/String")
    assert str(caught.value) == "String.data: cannot encode as UTF-8 (surrogates not allowed)"


def test_bools_where_numbers_go_are_refused() -> None:
    for full_name, value in (
        ("std_msgs/msg/UInt32", {"data": True}),
        ("std_msgs/msg/Int32MultiArray", {"data": [True]}),
        ("std_msgs/msg/Float32MultiArray", {"data": [True]}),
    ):
        for outcome in encode_both(full_name, value):
            assert isinstance(outcome, EncodeError), (full_name, value)


@pytest.mark.parametrize(
    "value",
    [{"elbow\udc80": 0.1}, {"elbow\udc80": {"position": 0.1, "velocity": 0.0}}],
    ids=["positions", "joint dicts"],
)
def test_a_joint_name_with_a_lone_surrogate_is_refused_by_both_paths(value: object) -> None:
    # JointState's fast path checked names for NUL only: the message was built, and rclpy's
    # serialisation raised a bare UnicodeEncodeError at publish.
    expected = "JointState.name: cannot encode as UTF-8 (surrogates not allowed)"
    for encode in (codecs.encode, wire.encode):
        with pytest.raises(EncodeError) as caught:
            encode(value, "sensor_msgs/msg/JointState")
        assert str(caught.value) == expected
