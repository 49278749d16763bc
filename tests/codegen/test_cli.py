"""The ``codecgen`` command's own checks of its options, made before anything is built."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.codegen.cli import main
from tests.codegen.conftest import TUTORIAL


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
