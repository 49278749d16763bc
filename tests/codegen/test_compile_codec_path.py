"""``codecgen build PKG --out DIR``, ``codecgen check`` and the registry agree on any folder."""

from __future__ import annotations

import importlib
import shutil
import sys
from collections.abc import Iterator
from pathlib import Path

import pyconnect_generated
import pytest

from pyconnect import codecs
from pyconnect.codecs import search_path
from pyconnect.codegen.build import DEFAULT_PACKAGES, default_out_dir, render_tree, stale_files
from pyconnect.codegen.cli import main

EXTRA = "rmw_dds_common"  # installed with the wheels, not one of generated/'s packages


@pytest.fixture
def codec_path(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Leave ``pyconnect_generated`` and its search path as they were."""
    saved = list(pyconnect_generated.__path__)
    yield
    monkeypatch.delenv(search_path.ENV_VAR, raising=False)
    pyconnect_generated.__path__[:] = saved
    for name in [m for m in sys.modules if m.startswith(f"pyconnect_generated.{EXTRA}")]:
        del sys.modules[name]


def test_check_checks_what_build_wrote(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert EXTRA not in DEFAULT_PACKAGES
    assert main(["build", EXTRA, "--out", str(tmp_path)]) == 0
    assert main(["check", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out.endswith(f"codecgen: {tmp_path} is up to date\n")
    index = tmp_path / "pyconnect_generated" / EXTRA / "index.py"
    index.write_text(index.read_text() + "# edited\n")
    assert main(["check", "--out", str(tmp_path)]) == 1
    assert f"pyconnect_generated/{EXTRA}/index.py" in capsys.readouterr().err


def test_an_extra_package_in_generated_is_not_stale(tmp_path: Path) -> None:
    """A copy of generated/ plus one more package: check passes, and so does the staleness test."""
    shutil.copytree(default_out_dir() / "pyconnect_generated", tmp_path / "pyconnect_generated")
    assert main(["build", EXTRA, "--out", str(tmp_path)]) == 0
    assert main(["check", "--out", str(tmp_path)]) == 0
    assert stale_files(render_tree(DEFAULT_PACKAGES), tmp_path) == []


@pytest.mark.usefixtures("codec_path")
def test_the_registry_finds_codecs_in_an_out_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert main(["build", EXTRA, "--out", str(tmp_path)]) == 0
    monkeypatch.setenv(search_path.ENV_VAR, str(tmp_path))
    search_path.refresh()
    module = importlib.import_module(f"pyconnect_generated.{EXTRA}.dict_codecs")
    assert Path(module.__file__ or "").is_relative_to(tmp_path)
    codec = codecs.Registry().lookup_dict(f"{EXTRA}/msg/Gid")
    assert codec.to_dict.__module__ == module.__name__
    msg = codec.from_dict({"data": list(range(16))})
    assert list(msg.data) == list(range(16))
    assert codec.from_dict(codec.to_dict(msg)) == msg
