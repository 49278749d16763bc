"""``codecgen build PKG --out DIR``, ``codecgen check`` and the registry agree on any folder."""

from __future__ import annotations

import importlib
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pyconnect_generated
import pytest

from pyconnect import codecs
from pyconnect.codecs import search_path
from pyconnect.codegen.build import DEFAULT_PACKAGES, default_out_dir, render_tree, stale_files
from pyconnect.codegen.cli import main
from pyconnect.codegen.compile_install import InstallLayout
from tests.codegen.test_compile import TIMEOUT, bare_environment

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


# Run against a regular (wheel) install of pyconnect: prints where each codec module came from.
_NON_EDITABLE = """
import sys
import pyconnect
from pyconnect import codecs
print("PYCONNECT", pyconnect.__file__)
for name in ("rmw_dds_common/msg/Gid", "tutorial_interfaces/msg/Num"):
    module = codecs.Registry().lookup_dict(name).to_dict.__module__
    print("CODEC", name, sys.modules[module].__file__)
"""


def test_a_wheel_install_finds_out_folders_and_compiled_codecs(
    compiled_prefix: Path, tmp_path: Path
) -> None:
    """pyconnect installed from its wheel (not editable): the same search path works."""
    root = Path(__file__).resolve().parents[2]
    pip = [sys.executable, "-m", "pip", "-q"]
    subprocess.run(
        [*pip, "wheel", str(root), "--no-deps", "-w", str(tmp_path / "wheel")],
        check=True,
        capture_output=True,
    )
    wheel = next((tmp_path / "wheel").glob("*.whl"))
    site = tmp_path / "site"
    subprocess.run(
        [*pip, "install", "--no-deps", "--target", str(site), str(wheel)],
        check=True,
        capture_output=True,
    )
    out = tmp_path / "out"
    assert main(["build", EXTRA, "--out", str(out)]) == 0
    env = bare_environment(compiled_prefix)
    env.update(PYTHONPATH=str(site), **{search_path.ENV_VAR: str(out)})
    result = subprocess.run(
        [sys.executable, "-c", _NON_EDITABLE],
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        check=False,
    )
    lines = result.stdout.splitlines()
    assert len(lines) == 3, result.stderr
    assert Path(lines[0].split()[1]).is_relative_to(site)
    gid = Path(lines[1].split()[2])
    assert gid == out / "pyconnect_generated" / EXTRA / "dict_codecs.py"
    num = Path(lines[2].split()[2])
    assert num == compiled_prefix.joinpath(
        InstallLayout.for_prefix(compiled_prefix).codecs("tutorial_interfaces"), "dict_codecs.py"
    )
