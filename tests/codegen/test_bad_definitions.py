"""Definitions rosidl cannot build are one line naming the file and line, exit status 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.codegen.cli import main

_INF = "(rosidl's generated code cannot spell inf or nan)"


def build(root: Path, files: dict[str, bytes], tmp_path: Path) -> int:
    for relative, data in files.items():
        (root / relative).parent.mkdir(parents=True, exist_ok=True)
        (root / relative).write_bytes(data)
    return main(["build", "--from", str(root), "--out", str(tmp_path / "out")])


@pytest.mark.timeout(60)
@pytest.mark.parametrize(
    ("files", "expected"),
    [
        ({"msg/A.msg": b"A[] children\nint32 v\n"},
         "msg/A.msg:1: recursive type tb_msgs/msg/A -> tb_msgs/msg/A "
         "(a ROS type cannot contain itself)"),
        ({"msg/A.msg": b"B b\n", "msg/B.msg": b"int8 x\nC[<=2] c\n", "msg/C.msg": b"# c\nA a\n"},
         "msg/A.msg:1: recursive type tb_msgs/msg/A -> tb_msgs/msg/B -> tb_msgs/msg/C -> "
         "tb_msgs/msg/A (a ROS type cannot contain itself)"),
        ({"msg/A.msg": b"float32 f inf\n"}, f"msg/A.msg:1: the default of f is not finite: inf {_INF}"),
        ({"msg/A.msg": b"int8 a\nfloat64 X=nan\n"},
         f"msg/A.msg:2: the value of X is not finite: nan {_INF}"),
        ({"msg/A.msg": b"float64 y 1e400\n"}, f"msg/A.msg:1: the default of y is not finite: inf {_INF}"),
        ({"msg/A.msg": b"# x\nint32 a\nfloat64[] z [1.0, -inf]\n"},
         f"msg/A.msg:3: the default of z is not finite: (1.0, -inf) {_INF}"),
        ({"srv/S.srv": b"int32 a\n---\n# c\nfloat32 NAN_C=nan\n"},
         f"srv/S.srv:4: the value of NAN_C is not finite: nan {_INF}"),
        ({"msg/A.msg": b"float32 f 1e39\n"},
         "msg/A.msg:1: the default of f is out of float32's range: 1e+39 (|x| < 3.4028235677973366e+38)"),
        ({"msg/A.msg": b"int8 a\nfloat32[] fs [1.0, -1e39]\n"},
         "msg/A.msg:2: the default of fs is out of float32's range: -1e+39 (|x| < 3.4028235677973366e+38)"),
        ({"srv/S.srv": b"int32 a\n---\nfloat32 BIG=3.5e38\n"},
         "srv/S.srv:3: the value of BIG is out of float32's range: 3.5e+38 (|x| < 3.4028235677973366e+38)"),
        ({"msg/A.msg": b"int32 x\n\xff\xfe int32 y\n"}, "msg/A.msg:2: not UTF-8 text (bytes ff)"),
        ({"msg/A.msg": b"int32 x\n", "package.xml": b"<name>tb_msgs</name>\xe9\n"},
         "package.xml:1: not UTF-8 text (bytes e9)"),
        ({"msg/Stamp.msg": b"time stamp\nint32 v\n"}, "msg/Stamp.msg:1: unknown type 'time'"),
        ({"srv/S.srv": b"int32 a\n---\n# c\nduration[] d\n"}, "srv/S.srv:4: unknown type 'duration'"),
    ],
)  # fmt: skip
def test_bad_definitions_are_one_line_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], files: dict[str, bytes], expected: str
) -> None:
    root = tmp_path / "tb_msgs"
    assert build(root, files, tmp_path) == 2
    assert capsys.readouterr().err == f"codecgen: {root}/{expected}\n"


def test_finite_defaults_and_constants_still_build(tmp_path: Path) -> None:
    files = {"msg/A.msg": b"float64 y 1e308\nfloat32 Z=-1.5\nfloat64[] z [1.0, -2.0]\n"
                          b"float32 m 3.4028235e38\nfloat32[] ms [-3.4028235e38]\n"}
    assert build(tmp_path / "tb_msgs", files, tmp_path) == 0
