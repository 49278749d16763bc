"""Field and constant names rosidl's generated code cannot use: refused by ``--compile`` only.

rosidl builds ``int32 from`` into a Python class that does not import (a warning, exit 0) and
``int32 class`` into C that does not compile; pyconnect's own generated code escapes every
name, so ``build --from`` keeps them (a wire-only peer or a bag may carry such types).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.codecs import wire
from pyconnect.codegen.cli import main
from pyconnect.typesys.loading import load_packages
from pyconnect.typesys.names import compiled_name_problem

_PY = "a Python keyword (the Python class rosidl generates would not import)"
_C = "a C keyword (the C code rosidl generates would not compile)"
_CPP = "a C++ keyword (the C++ type support rosidl generates would not compile)"


@pytest.mark.parametrize(
    ("files", "expected"),
    [
        ({"msg/Kw.msg": "int32 from\nfloat64 lambda\n", "msg/Fine.msg": "int32 x\n"},
         f"msg/Kw.msg:1: kw_msgs/msg/Kw: the field name 'from' is {_PY}; rename it"),
        ({"msg/Kw.msg": "# c\nint32 ok\nint32 switch\n"},
         f"msg/Kw.msg:3: kw_msgs/msg/Kw: the field name 'switch' is {_C}; rename it"),
        ({"srv/Kc.srv": "int32 a\n---\n# x\nint32 operator\n"},
         f"srv/Kc.srv:4: kw_msgs/srv/Kc_Response: the field name 'operator' is {_CPP}; rename it"),
        ({"msg/Kw.idl": "module kw_msgs { module msg {\n"
                        "  module Kw_Constants { const long this = 1; };\n"
                        "  struct Kw { long x; };\n}; };\n"},
         f"msg/Kw.idl:2: kw_msgs/msg/Kw: the constant name 'this' is {_CPP}; rename it"),
    ],
)  # fmt: skip
def test_compile_refuses_names_rosidl_cannot_use(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], files: dict[str, str], expected: str
) -> None:
    root = tmp_path / "kw_msgs"
    for relative, text in files.items():
        (root / relative).parent.mkdir(parents=True, exist_ok=True)
        (root / relative).write_text(text)
    prefix = tmp_path / "prefix"
    assert main(["build", "--compile", str(root), "--prefix", str(prefix)]) == 2
    assert capsys.readouterr().err == f"codecgen: {root}/{expected}\n"
    assert not prefix.exists(), "refused before anything is built"


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        # rosidl builds these with exit 0: the class does not import (`@builtins.property` then
        # names the field), or repr() and pyconnect's codecs fail on the replaced method.
        ("int32 builtins\nint32 z\n",
         "msg/M.msg:1: kw_msgs/msg/M: the field name 'builtins' is the module the Python class "
         "rosidl generates takes its property decorator from (a field after it makes the class "
         "not import); rename it"),
        ("int32 a\nint32 get_fields_and_field_types\n",
         "msg/M.msg:2: kw_msgs/msg/M: the field name 'get_fields_and_field_types' is a method of "
         "the Python class rosidl generates (the field would replace it: printing the message "
         "and pyconnect's codecs fail); rename it"),
        ("int32 a\nint32 SLOT_TYPES=1\n",
         "msg/M.msg:2: kw_msgs/msg/M: the constant name 'SLOT_TYPES' is an attribute of the "
         "Python class rosidl generates (the constant would hide it: pyconnect cannot read the "
         "type from the class); rename it"),
        # Or C that fails to compile, with an error naming a generated file in a deleted folder.
        ("int32 a\nint32 linux\n",
         "msg/M.msg:2: kw_msgs/msg/M: the field name 'linux' is a C macro on Linux (the C code "
         "rosidl generates would not compile); rename it"),
        ("# x\nint32 errno\n",
         "msg/M.msg:2: kw_msgs/msg/M: the field name 'errno' is a C macro on Linux (the C code "
         "rosidl generates would not compile); rename it"),
        ("int32 int32_t\nint32 z\n",
         "msg/M.msg:1: kw_msgs/msg/M: the field name 'int32_t' is a C type of rosidl's structs "
         "(the C++ type support would not compile); rename it"),
    ],
)  # fmt: skip
def test_compile_refuses_names_rosidl_builds_into_a_broken_package(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, expected: str
) -> None:
    root = tmp_path / "kw_msgs"
    (root / "msg").mkdir(parents=True)
    (root / "msg" / "M.msg").write_text(text)
    prefix = tmp_path / "prefix"
    assert main(["build", "--compile", str(root), "--prefix", str(prefix)]) == 2
    assert capsys.readouterr().err == f"codecgen: {root}/{expected}\n"
    assert not prefix.exists(), "refused before anything is built"


def test_build_from_keeps_keyword_fields_and_its_codecs_work(tmp_path: Path) -> None:
    root = tmp_path / "kw_msgs"
    (root / "msg").mkdir(parents=True)
    (root / "msg" / "Kw.msg").write_text("int32 from\nfloat64 lambda\nint32 class\n")
    assert main(["build", "--from", str(root), "--out", str(tmp_path / "out")]) == 0
    _, types = load_packages(folders=[root])
    codec = wire.wire_codec("kw_msgs/msg/Kw", definition=(root / "msg" / "Kw.msg").read_text())
    value = {"from": 3, "lambda": 1.5, "class": -2}
    assert codec.to_dict(codec.from_dict(value)) == value
    assert [f.name for f in types.get("kw_msgs/msg/Kw").fields] == ["from", "lambda", "class"]


def test_ordinary_names_pass() -> None:
    for name in ("data", "type", "match", "id", "string_value", "Class", "FROM", "ELSE"):
        assert compiled_name_problem(name) is None, name


def test_a_field_named_msg_type_has_working_codecs_and_views(tmp_path: Path) -> None:
    # The views name their type in a class attribute: no field may meet it (a slot and a class
    # attribute of one name cannot be defined together).
    text = "int32 msg_type\nstring name\nint32 MSG_TYPE=3\n"
    codec = wire.wire_codec("mtf_msgs/msg/Tagged", definition=text)
    value = {"msg_type": 7, "name": "x"}
    data = codec.from_dict(value)
    assert codec.to_dict(data) == value
    view = codec.decode_view(data)
    assert (view.msg_type, view.name) == (7, "x")
    assert repr(view) == "mtf_msgs/msg/Tagged(msg_type=7, name='x')"
    assert codec.from_dict(view) == data  # a view encodes like its dict
    root = tmp_path / "mtf_msgs"
    (root / "msg").mkdir(parents=True)
    (root / "msg" / "Tagged.msg").write_text(text)
    out = tmp_path / "out"
    assert main(["build", "--from", str(root), "--out", str(out)]) == 0
    source = (out / "pyconnect_generated" / "mtf_msgs" / "wire_codecs.py").read_text()
    namespace: dict[str, object] = {}
    exec(compile(source, "wire_codecs.py", "exec"), namespace)  # the module defines its classes
    assert sorted(namespace["LITTLE"]) == ["mtf_msgs/msg/Tagged"]  # type: ignore[call-overload]
