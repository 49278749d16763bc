"""Type names in generated modules: any valid name works, names that would meet are refused.

A type may be named like a name the templates use themselves (``Struct``, ``FieldError``, ``Any``):
its derived names are escaped (``symbols.RESERVED``). Two types that one module would name alike
(``HTTPServer``, ``HttpServer``) make ``codecgen build`` fail instead of one replacing the other.
"""

from __future__ import annotations

import ast
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from pyconnect.codegen.build import default_out_dir
from pyconnect.codegen.cli import main
from pyconnect.codegen.compile_generate import adapt_interfaces, run_generators
from pyconnect.codegen.compile_package import resolve_dependencies
from pyconnect.codegen.symbols import RESERVED, Symbols
from pyconnect.typesys.packages import ament_prefixes, folder_interface_files

GENERATED = default_out_dir() / "pyconnect_generated"
PACKAGE = "reserved_names"
# What a name derived from a type can look like: a type name, or a service or action part's
# (``SetBool_Request``, ``Fibonacci_SendGoal_Request``), or an escaped TypedDict (``Typed_Dict``).
TYPE_SHAPED = re.compile(r"[A-Z][A-Za-z0-9]*(_[A-Z][a-z][A-Za-z0-9]*)*")
# The header lines naming the types a generated module holds.
HEADER_TYPE = re.compile(r"^#   ([a-z][a-z0-9_]*/(?:msg|srv|action)/\w+)$", re.MULTILINE)

# Every reserved name as a type, plus ordinary types that use them as fields; ``Typed`` makes
# ``TypedDict`` and ``Thing`` the TypedDict name ``ThingDict``, which is a type here too.
DEFINITIONS = {
    **{f"msg/{name}.msg": "int32 x\n" for name in sorted(RESERVED)},
    "msg/Typed.msg": "int32 x\n",
    "msg/Thing.msg": "int32 x\n",
    "msg/ThingDict.msg": "Thing thing\n",
    "msg/Plain.msg": "Struct s\nFieldError[] errors\nTyped typed\nEMPTY[2] empties\nstring name\n",
    "srv/Mapping.srv": "Any a\n---\nStruct s\n",
}
VALUES = {
    **{f"{PACKAGE}/msg/{name}": {"x": n} for n, name in enumerate(sorted(RESERVED))},
    f"{PACKAGE}/msg/Typed": {"x": -1},
    f"{PACKAGE}/msg/ThingDict": {"thing": {"x": 7}},
    f"{PACKAGE}/msg/Plain": {
        "s": {"x": 1},
        "errors": [{"x": 2}, {"x": 3}],
        "typed": {"x": 4},
        "empties": [{"x": 5}, {"x": 6}],
        "name": "plain",
    },
    f"{PACKAGE}/srv/Mapping_Request": {"a": {"x": 8}},
    f"{PACKAGE}/srv/Mapping_Response": {"s": {"x": 9}},
}
# Run in a child process: the rosidl classes of the package are importable there only.
ROUND_TRIP = """
import json, sys, typing
from pyconnect import codecs
import pyconnect_generated.reserved_names.typed_dicts as typed_dicts

registry = codecs.Registry()
report = {
    "typed_dicts": sorted(n for n in vars(typed_dicts) if n.endswith("Dict")),
    "typing_kept": typed_dicts.TypedDict is typing.TypedDict,
}
for name, value in json.loads(sys.argv[1]).items():
    dict_codec, wire_codec = registry.lookup_dict(name), registry.wire_codec(name)
    cdr = wire_codec.from_dict(value)
    report[name] = [
        dict_codec.to_dict(dict_codec.from_dict(value)) == value,
        wire_codec.to_dict(cdr) == value,
        type(wire_codec.decode_view(cdr)).__name__,
    ]
errors = []
for name in ("reserved_names/msg/FieldError", "reserved_names/msg/Struct"):
    for call in (
        lambda: registry.lookup_dict(name).from_dict({"x": "no"}),
        lambda: registry.wire_codec(name).from_dict({"x": "no"}),
        lambda: registry.wire_codec(name).to_dict(bytes([0, 1, 0, 0, 1])),
    ):
        try:
            call()
        except Exception as error:
            errors.append(f"{type(error).__name__}: {error}")
report["errors"] = errors
print(json.dumps(report))
"""


def _write_package(root: Path, files: dict[str, str]) -> Path:
    for relative, text in files.items():
        (root / relative).parent.mkdir(parents=True, exist_ok=True)
        (root / relative).write_text(text)
    return root


def _rosidl_python(folder: Path, build: Path) -> Path:
    """rosidl_generator_py's classes of ``folder``, uncompiled: enough for the dict codecs (only
    serialising needs the C type support), in seconds rather than a compiled package's minute."""
    files = folder_interface_files(folder)
    idl_files = adapt_interfaces(PACKAGE, folder, files, build)
    sources = run_generators(
        package=PACKAGE, build=build, idl_files=idl_files, interface_files=files,
        dependencies=resolve_dependencies({"builtin_interfaces", "service_msgs"}),
        prefixes=ament_prefixes(),
    )  # fmt: skip
    return sources.root("rosidl_generator_py")


def test_types_named_like_the_templates_names_round_trip(tmp_path: Path) -> None:
    folder = _write_package(tmp_path / PACKAGE, DEFINITIONS)
    out = tmp_path / "out"
    assert main(["build", "--from", str(folder), "--out", str(out)]) == 0
    classes = _rosidl_python(folder, tmp_path / "build")
    python_path = os.pathsep.join(p for p in (str(classes), os.environ.get("PYTHONPATH")) if p)
    result = subprocess.run(
        [sys.executable, "-c", ROUND_TRIP, json.dumps(VALUES)],
        env={**os.environ, "PYTHONPATH": python_path, "PYCONNECT_CODEC_PATH": str(out)},
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    for name in VALUES:
        short = name.rsplit("/", 1)[1]
        view = f"{short}_" if short in RESERVED else short
        assert report[name] == [True, True, view], name
    typed_dicts = {f"{name}Dict" for name in RESERVED} | {"MappingRequestDict", "PlainDict"}
    # "Typed_Dict": TypedDict is reserved; "Thing_Dict": the type ThingDict has that name.
    typed_dicts |= {"Typed_Dict", "Thing_Dict", "ThingDictDict"}
    assert typed_dicts <= set(report["typed_dicts"])
    assert report["typing_kept"]
    truncated = "int32 at offset 4 needs 4 bytes, 1 left"
    assert report["errors"] == [
        "FieldError: FieldError.x: expected int (int32), got str",
        "FieldError: FieldError.x: expected int (int32), got str",
        f"DecodeError: {PACKAGE}/msg/FieldError.x: truncated: {truncated}",
        "FieldError: Struct.x: expected int (int32), got str",
        "FieldError: Struct.x: expected int (int32), got str",
        f"DecodeError: {PACKAGE}/msg/Struct.x: truncated: {truncated}",
    ]


def _bound_and_read_names(tree: ast.Module) -> set[str]:
    """Every name a module binds or reads, at any depth (a local can shadow as well)."""
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            names.add(node.id)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
        elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.alias):
            names.add(node.asname or node.name.split(".")[0])
    return names


def test_generated_modules_use_no_type_shaped_name_that_is_not_reserved() -> None:
    """A template that starts using a name a type could have (an import such as ``Sequence``, a
    constant such as ``TABLE``) must add it to ``RESERVED``, or a type of that name breaks."""
    seen_reserved: set[str] = set()
    modules = sorted(GENERATED.glob("*/*.py"))
    assert len(modules) > 50
    for path in modules:
        package, text = path.parent.name, path.read_text(encoding="utf-8")
        own = HEADER_TYPE.findall(text)
        symbols = Symbols(package, frozenset((package, n.rsplit("/", 1)[1]) for n in own))
        derived = {symbols.cls(n) for n in own} | {symbols.typed_dict(n) for n in own}
        shaped = {n for n in _bound_and_read_names(ast.parse(text)) if TYPE_SHAPED.fullmatch(n)}
        stray = sorted(shaped - derived - RESERVED)
        assert stray == [], f"{package}/{path.name}: add {stray} to symbols.RESERVED"
        seen_reserved |= shaped & RESERVED
    # And nothing stale there: each reserved name is one the generated code uses.
    assert seen_reserved == RESERVED


@pytest.mark.parametrize(
    ("files", "expected"),
    [
        (
            {"msg/HTTPServer.msg": "int32 port\n", "msg/HttpServer.msg": "string host\n"},
            "snake_pkg/msg/HttpServer: its generated name 'http_server' is also that of "
            "snake_pkg/msg/HTTPServer (rosidl would put both in one module _http_server.py): "
            "rename one of them",
        ),
        (
            {"srv/ThingDo.srv": "---\n", "msg/ThingDoRequest.msg": ""},
            "snake_pkg/srv/ThingDo_Request: its generated name 'thing_do_request' is also that of "
            "snake_pkg/msg/ThingDoRequest: rename one of them",
        ),
        (
            {"msg/None.msg": "int32 x\n"},
            "snake_pkg/msg/None: a Python keyword cannot name a type (rosidl's Python class "
            "could not be defined)",
        ),
    ],
)
def test_names_no_module_can_hold_are_one_line_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], files: dict[str, str], expected: str
) -> None:
    folder = _write_package(tmp_path / "snake_pkg", files)
    out = tmp_path / "out"
    assert main(["build", "--from", str(folder), "--out", str(out)]) == 2
    assert capsys.readouterr().err == f"codecgen: {expected}\n"
    assert not out.exists()
