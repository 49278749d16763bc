"""The ``codecgen`` command: its checks of its options (made before anything is built), and
what `check` advises."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.codegen.cli import main
from tests.codegen.conftest import TUTORIAL
from tests.missing_modules import without


@pytest.mark.parametrize("option", ["--from", "--compile"])
def test_an_interface_folder_instead_of_its_package_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str
) -> None:
    """``pkg/msg`` would build (and --compile install) a package named ``msg``."""
    out = tmp_path / "out"
    prefix = tmp_path / "prefix"
    where = ["--out", str(out)] if option == "--from" else ["--prefix", str(prefix)]
    assert main(["build", option, str(TUTORIAL / "msg"), *where]) == 2
    assert capsys.readouterr().err == (
        f"codecgen: {option} {TUTORIAL / 'msg'}: give the package folder, the one holding "
        f"msg/, srv/ or action/ (here {TUTORIAL})\n"
    )
    assert not out.exists()
    assert not prefix.exists()


@pytest.mark.parametrize(
    ("folder", "advice"),
    [
        ("out", "run `codecgen build`"),
        (
            "lib/python3.11/site-packages",
            "they belong to an installed package: reinstall it, do not rebuild them here",
        ),
    ],
)
def test_check_does_not_advise_rebuilding_an_installed_package(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], folder: str, advice: str
) -> None:
    """A build there would overwrite files pip installed (and lists in their RECORD)."""
    out = tmp_path / folder
    assert main(["build", "unique_identifier_msgs", "--out", str(out)]) == 0
    (out / "pyconnect_generated" / "unique_identifier_msgs" / "index.py").write_text("")
    capsys.readouterr()
    assert main(["check", "--out", str(out)]) == 1
    assert capsys.readouterr().err == (
        f"codecgen: 1 stale files in {out} ({advice}):\n"
        "  pyconnect_generated/unique_identifier_msgs/index.py\n"
    )


@pytest.mark.parametrize(
    ("missing", "reason"),
    [
        (
            "rosidl_adapter",
            "reading interface definitions needs rosidl's parsers (No module named "
            "'rosidl_adapter')",
        ),
        (
            "rosidl_generator_type_description",
            # Checked with the parsers since reading a definition also hashes it (the runtime's
            # register_definition and bag reading too), so the same one line.
            "reading interface definitions needs rosidl's parsers (No module named "
            "'rosidl_generator_type_description')",
        ),
    ],
)
def test_build_without_rosidl_is_one_line_naming_the_install(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    missing: str,
    reason: str,
) -> None:
    """As in an install where rosidl's wheels do not exist (not x86_64 Linux) and no ROS."""
    package = tmp_path / "my_msgs"
    (package / "msg").mkdir(parents=True)
    (package / "msg" / "Num.msg").write_text("int64 num\n")
    without(monkeypatch, missing)
    assert main(["build", "--from", str(package), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == (
        f"codecgen: {reason}: pip install 'pyconnect-ros[ros]' or source a ROS 2 Jazzy install\n"
    )


def test_a_type_defined_twice_is_one_line_naming_both_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """msg/A.msg beside A.msg, or one package in two folders: one definition silently replaced
    the other (and --compile failed in the C compiler)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "e2_msgs" / "msg").mkdir(parents=True)
    (tmp_path / "e2_msgs" / "msg" / "A.msg").write_text("int32 a\n")
    (tmp_path / "e2_msgs" / "A.msg").write_text("int32 b\n")
    assert main(["build", "--from", "e2_msgs", "--out", "out"]) == 2
    assert capsys.readouterr().err == (
        "codecgen: e2_msgs/A.msg: e2_msgs/msg/A is also defined in e2_msgs/msg/A.msg\n"
    )
    for folder, text in (("one", "int32 a\n"), ("two", "string s\n")):
        (tmp_path / folder / "dup_msgs" / "msg").mkdir(parents=True)
        (tmp_path / folder / "dup_msgs" / "msg" / "A.msg").write_text(text)
    assert main(["build", "--from", "one/dup_msgs", "--from", "two/dup_msgs", "--out", "o"]) == 2
    assert capsys.readouterr().err == (
        "codecgen: two/dup_msgs/msg/A.msg: dup_msgs/msg/A is also defined in "
        "one/dup_msgs/msg/A.msg\n"
    )
    assert not (tmp_path / "out").exists() and not (tmp_path / "o").exists()


def test_a_badly_named_file_is_named_so_not_an_unknown_type(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "lc_msgs" / "msg").mkdir(parents=True)
    (tmp_path / "lc_msgs" / "msg" / "lower_case.msg").write_text("int32 a\n")
    assert main(["build", "--from", "lc_msgs", "--out", "out"]) == 2
    assert capsys.readouterr().err == (
        "codecgen: lc_msgs/msg/lower_case.msg: 'lower_case' is an invalid message name. It "
        "should have the pattern '^[A-Z][A-Za-z0-9]*$'\n"
    )
