"""A compiler failure is one line naming the interface it compiled, not a deleted temp file."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.codegen.cli import main
from pyconnect.codegen.compile_toolchain import compiler_failure

LIBRARY = "libm_msgs__rosidl_generator_c.so"


def _build_folder(tmp_path: Path, *names: str) -> Path:
    """What rosidl_adapter leaves in a build folder: the .idl of each message."""
    build = tmp_path / ".codecgen-m_msgs-x1y2"
    for name in names:
        idl = build / "rosidl_adapter" / "m_msgs" / "msg" / f"{name}.idl"
        idl.parent.mkdir(parents=True, exist_ok=True)
        idl.write_text("")
    return build


def test_an_error_in_generated_code_names_the_interface(tmp_path: Path) -> None:
    build = _build_folder(tmp_path, "HTTPStatus", "X")
    header = build / "rosidl_generator_c/m_msgs/msg/detail/http_status__struct.h"
    stderr = (
        f"In file included from {build}/rosidl_generator_c/m_msgs/msg/detail/x__functions.c:7:\n"
        f"{header}:26:11: error: expected identifier or '(' before numeric constant\n"
        "   26 |   int32_t linux;\n"
    )
    message = compiler_failure(LIBRARY, stderr)
    assert message == (
        "the C/C++ code rosidl generated for m_msgs/msg/HTTPStatus does not compile "
        "(http_status__struct.h:26: expected identifier or '(' before numeric constant; building "
        f"{LIBRARY}): most likely a field, constant or default value of it C or C++ cannot take"
    )
    assert str(tmp_path) not in message


def test_an_error_in_an_installed_header_names_the_generated_file_that_included_it(
    tmp_path: Path,
) -> None:
    build = _build_folder(tmp_path, "X")
    stderr = (
        f"In file included from {build}/rosidl_generator_py/m_msgs/msg/_x_s.c:9:\n"
        "/usr/include/numpy/npy_common.h:237:19: error: two or more data types\n"
    )
    message = compiler_failure(LIBRARY, stderr)
    assert message.startswith(
        "the C/C++ code rosidl generated for m_msgs/msg/X does not compile "
        "(/usr/include/numpy/npy_common.h:237: two or more data types; "
    )
    assert str(tmp_path) not in message


def test_other_failures_keep_their_first_error_line() -> None:
    stderr = "/usr/bin/ld: cannot find -lfoo: No such file or directory\ncollect2: error: ld\n"
    assert compiler_failure(LIBRARY, stderr) == f"compiling {LIBRARY} failed: collect2: error: ld"
    assert compiler_failure(LIBRARY, "") == f"compiling {LIBRARY} failed: (no output)"


def test_a_default_c_cannot_take_names_the_interface_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # rosidl parses the newline of this default but writes it into a C string literal as is.
    root = tmp_path / "nl_msgs"
    (root / "msg").mkdir(parents=True)
    (root / "msg" / "Text.msg").write_text('int32 a\nstring b "a\\\\nb"\n')
    prefix = tmp_path / "prefix"
    assert main(["build", "--compile", str(root), "--prefix", str(prefix)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        "codecgen: the C/C++ code rosidl generated for nl_msgs/msg/Text does not compile "
        "(text__functions.c:"
    ), err
    assert err.count("\n") == 1
    assert str(prefix) not in err, "names no file of the deleted build folder"
