"""``codecgen build --compile`` options: a mix with the folder-build options is refused."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.codegen.cli import main
from tests.codegen.conftest import EXTRAS, TUTORIAL


def test_out_from_and_package_names_are_refused_with_compile(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """They would be ignored: nothing written to --out, a build the user asked for not done."""
    out = tmp_path / "out"
    prefix = tmp_path / "prefix"
    argv = ["build", "--compile", str(TUTORIAL), "--prefix", str(prefix)]
    argv += ["--from", str(EXTRAS), "--out", str(out), "std_msgs"]
    assert main(argv) == 2
    assert capsys.readouterr().err == (
        f"codecgen: --compile does not take --out, --from or package names (given: --out {out}, "
        f"--from {EXTRAS}, std_msgs): run those as a codecgen build of their own\n"
    )
    assert not out.exists()
    assert not prefix.exists()


@pytest.mark.parametrize(
    ("extra", "given"),
    [(["--out", "OUT"], "--out OUT"), (["std_msgs"], "std_msgs"), (["--from", "F"], "--from F")],
)
def test_each_ignored_option_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], given: str
) -> None:
    prefix = tmp_path / "prefix"
    assert main(["build", "--compile", str(TUTORIAL), "--prefix", str(prefix), *extra]) == 2
    assert f"(given: {given})" in capsys.readouterr().err
    assert not prefix.exists()


def test_prefix_and_force_without_compile_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    prefix = tmp_path / "prefix"
    argv = ["build", "std_msgs", "--out", str(out), "--prefix", str(prefix), "--force"]
    assert main(argv) == 2
    assert capsys.readouterr().err == (
        f"codecgen: --prefix {prefix} and --force only go with --compile DIR\n"
    )
    assert not out.exists()
