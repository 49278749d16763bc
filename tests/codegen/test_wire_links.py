"""Generated wire code links: each type's code lives in its own package's module, once.

Code compiled on the fly links to generated modules where they have the same type (RIHS01 hash
for hash) and compiles the rest, so a bag's own version of a nested type decodes as the bag says.
"""

from __future__ import annotations

import importlib
from typing import Any

import pytest

from pyconnect.codecs import wire
from pyconnect.codegen.build import default_out_dir

GENERATED = default_out_dir() / "pyconnect_generated"
SEPARATOR = "=" * 80
TIME_BLOCK = f"""
{SEPARATOR}
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""
# A Header as old robots wrote it (ROS 1's seq): not the generated std_msgs/msg/Header.
OLD_HEADER_BLOCK = f"""
{SEPARATOR}
MSG: std_msgs/Header
uint32 seq
builtin_interfaces/Time stamp
string frame_id
"""
READING = "std_msgs/Header header\nfloat64[] values\nstring note\n"


def _wire_module(package: str) -> Any:
    return importlib.import_module(f"pyconnect_generated.{package}.wire_codecs")


def _packages() -> list[str]:
    return sorted(p.parent.name for p in GENERATED.glob("*/wire_codecs.py"))


def test_every_type_has_its_code_in_its_own_package_module_only() -> None:
    seen: dict[str, str] = {}
    for package in _packages():
        module = _wire_module(package)
        views = [v for v in vars(module).values() if isinstance(v, type) and hasattr(v, "__msgtype__")]
        defined = sorted(v.__msgtype__ for v in views if v.__module__ == module.__name__)
        assert defined == sorted(module.LITTLE) == sorted(module.EXPORTED)
        for name in defined:
            assert name.split("/")[0] == package
            assert name not in seen, f"{name} is written in {seen.get(name)} and {package}"
            seen[name] = package
        assert set(module.FUNCTIONS["<", False]) == {
            f"{f.__name__}" for f in module.FUNCTIONS["<", False].values()
        }


def test_a_nested_type_of_another_package_is_imported_from_its_module() -> None:
    source = (GENERATED / "sensor_msgs" / "wire_codecs.py").read_text()
    assert "from pyconnect_generated.std_msgs.wire_codecs import (\n" in source
    assert 'std_msgs__header_decode = STD_MSGS__FUNCTIONS[E, view]["header_decode"]\n' in source
    assert "def header_decode" not in source
    assert "class Header:" not in source
    image = wire.wire_codec("sensor_msgs/msg/Image")
    cdr = image.from_dict({"header": {"stamp": {"sec": 5}, "frame_id": "cam"}, "height": 1})
    view = image.decode_view(cdr)
    assert type(view.header) is _wire_module("std_msgs").Header
    assert type(view.header.stamp) is _wire_module("builtin_interfaces").Time
    assert image.to_dict(cdr)["header"] == {"stamp": {"sec": 5, "nanosec": 0}, "frame_id": "cam"}


def test_generated_lines_fit_the_formatter() -> None:
    for path in GENERATED.glob("*/*.py"):
        long = [n for n, line in enumerate(path.read_text().splitlines(), 1) if len(line) > 100]
        assert long == [], f"{path.name} of {path.parent.name}: lines {long[:5]} exceed 100"


def test_on_the_fly_code_links_the_generated_types_with_the_same_hash() -> None:
    header_block = f"\n{SEPARATOR}\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\n"
    text = READING + header_block + "string frame_id\n" + TIME_BLOCK
    codec = wire.wire_codec("my_robot_msgs/msg/Reading", definition=text)
    value = {
        "header": {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": "base"},
        "values": [0.5, 1.5],
        "note": "ok",
    }
    cdr = codec.from_dict(value)
    assert codec.to_dict(cdr) == value
    view = codec.decode_view(cdr)
    assert type(view.header) is _wire_module("std_msgs").Header
    assert view.values.tolist() == [0.5, 1.5]
    # The Header part is the generated code's: byte for byte what std_msgs encodes.
    header = wire.wire_codec("std_msgs/msg/Header").from_dict(value["header"])
    assert bytes(cdr).startswith(bytes(header))


def test_on_the_fly_code_compiles_a_nested_type_the_text_defines_differently() -> None:
    codec = wire.wire_codec(
        "my_robot_msgs/msg/Reading", definition=READING + OLD_HEADER_BLOCK + TIME_BLOCK
    )
    value = {
        "header": {"seq": 9, "stamp": {"sec": 1, "nanosec": 2}, "frame_id": "base"},
        "values": [0.5],
        "note": "",
    }
    cdr = codec.from_dict(value)
    assert codec.to_dict(cdr) == value
    # CDR header, seq, sec, nanosec, frame_id "base\0", pad, count 1, pad, 0.5, note "\0", pad.
    assert bytes(cdr) == (
        b"\x00\x01\x00\x00" + b"\x09\x00\x00\x00" + b"\x01\x00\x00\x00" + b"\x02\x00\x00\x00"
        + b"\x05\x00\x00\x00base\x00" + b"\x00\x00\x00" + b"\x01\x00\x00\x00" + b"\x00" * 4
        + b"\x00\x00\x00\x00\x00\x00\xe0\x3f" + b"\x01\x00\x00\x00\x00" + b"\x00" * 3
    )  # fmt: skip
    view = codec.decode_view(cdr)
    assert type(view.header) is not _wire_module("std_msgs").Header
    assert view.header.seq == 9
    # Its Time is the generated one (same hash): linked, not compiled again.
    assert type(view.header.stamp) is _wire_module("builtin_interfaces").Time
    with pytest.raises(Exception) as raised:
        codec.from_dict({"header": {"seq": "nine"}})
    assert str(raised.value) == "Reading.header.seq: expected int (uint32), got str"


def test_generated_modules_hold_no_copies() -> None:
    # The sizes the issue tracks: each type's wire code once (today 18 copies of Time).
    copies = sum(
        (GENERATED / package / "wire_codecs.py").read_text().count("class Time:")
        for package in _packages()
    )
    assert copies == 1
