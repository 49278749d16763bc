"""Parsing .msg text never ends the process: what rosidl cannot convert is a DefinitionError."""

from __future__ import annotations

from pathlib import Path
from typing import Any, NoReturn

import pytest

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.parse import ParsedInterfaces, parse_interface_text


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("time stamp\nint32 v\n", "msg/Stamp.msg:1: unknown type 'time'"),
        ("# c\nint32 v\nduration[<=3] d  # ROS 1\n", "msg/Stamp.msg:3: unknown type 'duration'"),
    ],
)
def test_ros1_time_and_duration_are_unknown_types(text: str, expected: str) -> None:
    with pytest.raises(DefinitionError) as caught:
        parse_interface_text("my_pkg", Path("msg/Stamp.msg"), text, ParsedInterfaces())
    assert str(caught.value) == expected


def test_a_field_named_time_is_fine() -> None:
    parsed = ParsedInterfaces()
    parse_interface_text("my_pkg", Path("msg/T.msg"), "int32 time\nint32 duration\n", parsed)
    assert [f.name for f in parsed.messages[0].fields] == ["time", "duration"]


def test_rosidl_template_exiting_is_a_definition_error(monkeypatch: pytest.MonkeyPatch) -> None:
    import rosidl_adapter.resource

    def exits(*_args: Any, **_kwargs: Any) -> NoReturn:
        raise SystemExit(1)

    monkeypatch.setattr(rosidl_adapter.resource, "evaluate_template", exits)
    with pytest.raises(DefinitionError) as caught:
        parse_interface_text("my_pkg", Path("msg/T.msg"), "int32 v\n", ParsedInterfaces())
    assert str(caught.value) == "msg/T.msg: rosidl cannot convert it to IDL (it exited)"
