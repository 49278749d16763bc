"""``stale_files``: an output folder compared with a fresh build, for both folder layouts."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.codegen.build import render_tree, stale_files
from pyconnect.codegen.cli import main
from pyconnect.codegen.compile_install import CODECS_FOLDER, InstallLayout
from tests.codegen.test_compile import _copy_of

PACKAGE = "unique_identifier_msgs"  # small, and no other package's types in it
ROOT_FILES = ["pyconnect_generated/__init__.py", "pyconnect_generated/py.typed"]


def test_check_passes_on_the_codecs_a_compile_installed(
    compiled_prefix: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The install writes only ``pyconnect_generated/<pkg>/``: no root files are due there."""
    prefix = _copy_of(compiled_prefix, tmp_path / "prefix")  # only these two packages in it
    codecs = InstallLayout.for_prefix(prefix).python / CODECS_FOLDER
    assert main(["check", "--out", str(codecs)]) == 0
    assert capsys.readouterr().out == f"codecgen: {codecs} is up to date\n"


def test_root_files_are_optional_only_in_an_install_codec_folder(tmp_path: Path) -> None:
    files = render_tree([PACKAGE])
    for folder in (tmp_path / "out", tmp_path / CODECS_FOLDER):
        assert main(["build", PACKAGE, "--out", str(folder)]) == 0
        for relative in ROOT_FILES:
            (folder / relative).unlink()
    assert stale_files(files, tmp_path / "out") == ROOT_FILES
    assert stale_files(files, tmp_path / CODECS_FOLDER) == []
    # Present but out of date is stale in either layout.
    (tmp_path / CODECS_FOLDER / ROOT_FILES[0]).write_text("# edited\n")
    assert stale_files(files, tmp_path / CODECS_FOLDER) == ROOT_FILES[:1]
