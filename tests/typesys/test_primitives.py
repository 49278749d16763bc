"""The one primitive table agrees with struct, numpy and rosidl's Python classes."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from test_msgs.msg import BasicTypes

from pyconnect.codegen import DefinitionError
from pyconnect.errors import PyconnectError
from pyconnect.typesys.names import class_path, split_part
from pyconnect.typesys.primitives import (
    INTEGER_RANGES,
    NUMPY_DTYPES,
    PRIMITIVE_NAMES,
    PRIMITIVE_SIZES,
    ROSIDL_NAMES,
    STRUCT_CODES,
)


@pytest.mark.parametrize("name", PRIMITIVE_NAMES)
def test_sizes_codes_and_dtypes_agree(name: str) -> None:
    assert struct.calcsize("<" + STRUCT_CODES[name]) == PRIMITIVE_SIZES[name]
    assert np.dtype(NUMPY_DTYPES[name]).itemsize == PRIMITIVE_SIZES[name]


@pytest.mark.parametrize("name", sorted(INTEGER_RANGES))
def test_integer_ranges_are_the_dtype_ranges(name: str) -> None:
    info = np.iinfo(NUMPY_DTYPES[name])
    assert INTEGER_RANGES[name] == (int(info.min), int(info.max))


def test_rosidl_names_are_what_the_classes_report() -> None:
    reported = set(BasicTypes.get_fields_and_field_types().values())
    ours = {ROSIDL_NAMES.get(name, name) for name in PRIMITIVE_NAMES if name != "char"}
    assert ours == reported


def test_part_names() -> None:
    assert split_part("action", "Fibonacci_SendGoal_Request") == ("Fibonacci", "SendGoal_Request")
    assert split_part("action", "Fibonacci_FeedbackMessage") == ("Fibonacci", "FeedbackMessage")
    assert split_part("srv", "SetBool_Event") == ("SetBool", "Event")
    assert split_part("srv", "SetBool") is None
    assert split_part("msg", "Image_Request") is None
    assert class_path("std_srvs/srv/SetBool_Request") == ("std_srvs.srv", "SetBool.Request")
    assert class_path("test_msgs/action/Fibonacci_GetResult_Event") == (
        "test_msgs.action",
        "Fibonacci.Impl.GetResultService.Event",
    )
    assert class_path("sensor_msgs/msg/Image") == ("sensor_msgs.msg", "Image")


def test_definition_error_is_a_pyconnect_error() -> None:
    error = DefinitionError("bad line", path="msg/Foo.msg", line=3)
    assert isinstance(error, PyconnectError)
    assert str(error) == "msg/Foo.msg:3: bad line"
