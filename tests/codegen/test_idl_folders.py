"""Folders of .idl files: ``build --from`` and ``--compile`` read them as rosidl's build does."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from pyconnect.codegen.cli import main
from pyconnect.typesys.loading import load_packages
from pyconnect.typesys.packages import folder_interface_files
from tests.codegen.test_compile import TIMEOUT, bare_environment

POINT_IDL = """\
module idl_msgs {
  module msg {
    struct Point {
      double x;
      octet tag;
      sequence<octet, 4> payload;
    };
  };
};
"""
BESIDE_IDL = """\
// beside msg/: its namespace comes from its modules
module idl_msgs { module msg { struct Beside { string name; }; }; };
"""
FILES = {
    "msg/Point.idl": POINT_IDL,
    "Beside.idl": BESIDE_IDL,
    "msg/Uses.msg": "Point p\nBeside b\n",
}


def write(root: Path, files: dict[str, str]) -> Path:
    for relative, text in files.items():
        (root / relative).parent.mkdir(parents=True, exist_ok=True)
        (root / relative).write_text(text)
    return root


def test_build_from_reads_idl_files(tmp_path: Path) -> None:
    root = write(tmp_path / "idl_msgs", FILES)
    assert main(["build", "--from", str(root), "--out", str(tmp_path / "out")]) == 0
    index = (tmp_path / "out" / "pyconnect_generated" / "idl_msgs" / "index.py").read_text()
    for name in ("Point", "Beside", "Uses"):
        assert f'"idl_msgs/msg/{name}": (\n        "RIHS01_' in index
    # The same type written as .msg has the same RIHS01 hash, as in rosidl.
    _, from_idl = load_packages(folders=[root])
    msg_root = write(
        tmp_path / "msg" / "idl_msgs", {"msg/Point.msg": "float64 x\nbyte tag\nbyte[<=4] payload\n"}
    )
    _, from_msg = load_packages(folders=[msg_root])
    point = "idl_msgs/msg/Point"
    assert from_idl.get(point).type_hash == from_msg.get(point).type_hash
    assert from_idl.get(point).fields == from_msg.get(point).fields


def test_an_idl_beside_its_msg_is_rosidl_adapters_copy(tmp_path: Path) -> None:
    """An installed share/ folder holds both: the .msg is the definition, the .idl not a second."""
    root = write(
        tmp_path / "idl_msgs", {"msg/Point.msg": "float64 x\n", "msg/Point.idl": POINT_IDL}
    )
    assert folder_interface_files(root) == [root / "msg" / "Point.msg"]


@pytest.mark.parametrize(
    ("files", "expected"),
    [
        ({"msg/Point.idl": POINT_IDL.replace("module idl_msgs", "module other_msgs")},
         "msg/Point.idl: declares other_msgs::msg, expected module idl_msgs::msg "
         "(the folder's package and namespace)"),
        ({"srv/Point.idl": POINT_IDL},
         "srv/Point.idl: declares idl_msgs::msg, expected module idl_msgs::srv "
         "(the folder's package and namespace)"),
        ({"msg/Spot.idl": POINT_IDL}, "msg/Spot.idl: declares no type named Spot (the file's name)"),
        ({"Point.idl": "struct Point { double x; };\n"},
         "Point.idl: declares Point outside a `module <package> { module msg|srv|action { } }`"),
        ({"Point.idl": "module idl_msgs { module types { struct Point { double x; }; }; };\n"},
         "Point.idl: declares Point outside a `module <package> { module msg|srv|action { } }`"),
    ],
)  # fmt: skip
def test_misplaced_idl_files_are_one_line_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], files: dict[str, str], expected: str
) -> None:
    root = write(tmp_path / "idl_msgs", files)
    assert main(["build", "--from", str(root), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == f"codecgen: {root}/{expected}\n"


_ROUND_TRIP = """
from idl_msgs.msg import Beside, Point, Uses
from rclpy.serialization import deserialize_message, serialize_message
from pyconnect.codecs import wire
msg = Uses(p=Point(x=1.5, tag=b"\\x07", payload=[b"a", b"b"]), b=Beside(name="hi"))
value = wire.decode(serialize_message(msg), "idl_msgs/msg/Uses")
print(value)
print(deserialize_message(wire.encode(value, "idl_msgs/msg/Uses"), Uses) == msg)
"""


def test_compile_builds_idl_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    root = write(tmp_path / "idl_msgs", FILES)
    prefix = tmp_path / "prefix"
    assert main(["build", "--compile", str(root), "--prefix", str(prefix)]) == 0
    assert "codecgen: idl_msgs: built" in capsys.readouterr().out
    result = subprocess.run(
        [sys.executable, "-c", _ROUND_TRIP],
        env=bare_environment(prefix),
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        check=False,
    )
    assert result.stdout == (
        "{'p': {'x': 1.5, 'tag': 7, 'payload': b'ab'}, 'b': {'name': 'hi'}}\nTrue\n"
    ), result.stderr


_NO_CHAR = "IDL char, wchar and long double are not supported; use uint8, uint16, float64"


@pytest.mark.parametrize(
    ("member", "line", "expected"),
    [
        ("char c;", 4, "unsupported IDL type 'char' of c"),
        ("sequence<wchar, 3> w;", 4, "unsupported IDL type 'wchar' of w"),
        ("long double big[2];", 4, "unsupported IDL type 'long double' of big"),
    ],
)
def test_unsupported_idl_types_name_file_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], member: str, line: int, expected: str
) -> None:
    text = f"module idl_msgs {{\n  module msg {{\n    struct Odd {{\n      {member}\n    }};\n  }};\n}};\n"
    root = write(tmp_path / "idl_msgs", {"msg/Odd.idl": text})
    assert main(["build", "--from", str(root), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == (
        f"codecgen: {root}/msg/Odd.idl:{line}: {expected} ({_NO_CHAR})\n"
    )
