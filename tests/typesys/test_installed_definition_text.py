"""The definition text pyconnect stores for installed types: byte for byte what rosbag2 Jazzy stores."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from pyconnect.typesys.definition_text import resolve_definition
from pyconnect.typesys.installed_definition_text import (
    DEFINITION_SEPARATOR,
    definition_encoding,
    installed_definition,
    interface_file,
)
from tests.typesys.idl_prefix import READING_IDL, SAMPLE_MSG, install_idl_package

SEPARATOR = "=" * 80


def _file(package: str, namespace: str, name: str) -> str:
    return interface_file(package, namespace, name).read_bytes().decode("utf-8")


# -- service events: rosbag2 Jazzy's `SRV:` layout ----------------------------------------------
def test_a_service_event_is_stored_as_its_srv_block_and_dependencies() -> None:
    """The raw .srv text alone left ParameterValue undefined where rcl_interfaces is not
    installed; every rosbag2 0.26 release writes this layout."""
    text = installed_definition("rcl_interfaces/srv/GetParameters_Event")
    assert text == (
        f"{SEPARATOR}\nSRV: rcl_interfaces/srv/GetParameters\n"
        + _file("rcl_interfaces", "srv", "GetParameters")
        + f"\n{SEPARATOR}\nMSG: rcl_interfaces/ParameterValue\n"
        + _file("rcl_interfaces", "msg", "ParameterValue")
    )
    assert definition_encoding(text) == "ros2msg"


def test_a_service_with_no_message_fields_is_stored_as_ros2msg() -> None:
    """rosbag2 Jazzy labels it "unknown", so no reader would use the text."""
    text = installed_definition("std_srvs/srv/SetBool_Event")
    assert text == f"{SEPARATOR}\nSRV: std_srvs/srv/SetBool\n" + _file("std_srvs", "srv", "SetBool")
    assert definition_encoding(text) == "ros2msg"


MEASURE_SRV = "Reading r\nSample s\n---\nbool ok\n"


@pytest.fixture
def measure_share(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """idlpkg (``Reading`` only in .idl, ``Sample.msg`` nesting it) with srv/Measure.srv."""
    share = install_idl_package(tmp_path / "prefix", monkeypatch)
    (share / "srv").mkdir()
    (share / "srv" / "Measure.srv").write_text(MEASURE_SRV)
    yield share
    monkeypatch.undo()
    installed_definition.cache_clear()
    from pyconnect.typesys.packages import installed_share_dirs

    installed_share_dirs.cache_clear()


def test_a_service_dependency_with_only_an_idl_file_is_stored_as_rosbag2_stores_it(
    measure_share: Path,
) -> None:
    """rosbag2 leaves the `MSG:` line of a dependency with no .msg file, then writes its .idl
    text; Sample's own Reading was written already (as rosbag2 counts it) and is not repeated."""
    text = installed_definition("idlpkg/srv/Measure_Event")
    assert text == (
        f"{SEPARATOR}\nSRV: idlpkg/srv/Measure\n{MEASURE_SRV}"
        f"\n{SEPARATOR}\nMSG: idlpkg/Reading\n"
        f"\n{SEPARATOR}\nIDL: idlpkg/Reading\n{READING_IDL}"
        f"\n{SEPARATOR}\nMSG: idlpkg/Sample\n{SAMPLE_MSG}"
    )
    assert definition_encoding(text) == "ros2idl"
    message, types = resolve_definition("idlpkg/srv/Measure_Event", text, "ros2idl")
    request = types.get(message.fields[1].type.element.name)
    assert request.nested_types == ("idlpkg/msg/Reading", "idlpkg/msg/Sample")
    assert [f.name for f in types.get("idlpkg/msg/Reading").fields] == ["value", "label"]


# -- line ends: rosbag2 reads the files with std::ifstream, which keeps CRLF ---------------------
@pytest.fixture
def crlf_share(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """idlpkg with CRLF files: msg/Outer.msg nesting msg/Inner.msg, srv/Ask.srv, its .idl ones."""
    share = install_idl_package(tmp_path / "prefix", monkeypatch)
    (share / "srv").mkdir()
    files = {
        "msg/Outer.msg": "# outer\r\nint32 a\r\nInner inner\r\n",
        "msg/Inner.msg": "# inner\r\nfloat64 v\r\n",
        "srv/Ask.srv": "Inner q\r\n---\r\nbool ok\r\n",
        "msg/Reading.idl": READING_IDL.replace("\n", "\r\n"),
    }
    for relative, text in files.items():
        (share / relative).write_bytes(text.encode())
    yield share
    monkeypatch.undo()
    installed_definition.cache_clear()
    from pyconnect.typesys.packages import installed_share_dirs

    installed_share_dirs.cache_clear()


def test_crlf_files_are_stored_byte_for_byte(crlf_share: Path) -> None:
    """Read as text, their CRLF became LF: not what rosbag2 stores."""
    inner = f"\n{DEFINITION_SEPARATOR}\nMSG: idlpkg/Inner\n# inner\r\nfloat64 v\r\n"
    outer = installed_definition("idlpkg/msg/Outer")
    assert outer == "# outer\r\nint32 a\r\nInner inner\r\n" + inner
    event = installed_definition("idlpkg/srv/Ask_Event")
    assert event == f"{SEPARATOR}\nSRV: idlpkg/srv/Ask\nInner q\r\n---\r\nbool ok\r\n" + inner
    reading = installed_definition("idlpkg/msg/Reading")
    assert reading == f"{SEPARATOR}\nIDL: idlpkg/msg/Reading\n" + READING_IDL.replace("\n", "\r\n")
    message, _types = resolve_definition("idlpkg/msg/Outer", outer, "ros2msg")
    assert message.nested_types == ("idlpkg/msg/Inner",)
    message, _types = resolve_definition("idlpkg/srv/Ask_Event", event, "ros2msg")
    assert [f.name for f in message.fields] == ["info", "request", "response"]
