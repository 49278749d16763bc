"""``pyconnect run``: the program gets its own arguments, and the settings without a false alarm."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from pyconnect.ros import large_messages
from tests.commands.processes import ROOT, WAIT


def _pyconnect_run(
    *argv: str, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "pyconnect.cli", "run", *argv],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=WAIT,
        env=env if env is not None else dict(os.environ, PYCONNECT_LARGE_MESSAGES="0"),
        check=False,
    )


def test_everything_after_the_module_goes_to_the_module(tmp_path: Path) -> None:
    data = tmp_path / "data.json"
    data.write_text('{"b": 1, "a": 2}')
    done = _pyconnect_run("-m", "json.tool", "--sort-keys", str(data))
    assert (done.returncode, done.stdout) == (0, '{\n    "a": 2,\n    "b": 1\n}\n')
    done = _pyconnect_run("-m", "json.tool", "--help")
    assert done.returncode == 0
    assert done.stdout.startswith("usage: python -m json.tool ")


def test_a_script_gets_its_options_too(tmp_path: Path) -> None:
    script = tmp_path / "args.py"
    script.write_text("import sys\nprint(sys.argv[1:])\n")
    done = _pyconnect_run(str(script), "--help", "-m", "x")
    assert (done.returncode, done.stdout) == (0, "['--help', '-m', 'x']\n")


def test_a_module_must_be_named() -> None:
    done = _pyconnect_run("-m")
    assert (done.returncode, done.stderr) == (
        2,
        "pyconnect: error: run: argument -m: expected a module name\n",
    )


def test_the_setting_on_applies_without_a_warning(tmp_path: Path) -> None:
    # The launcher's own import of pyconnect.ros configures it first: its profile is no user's.
    if large_messages.segment_bytes() < 8 * 1024 * 1024:
        pytest.skip("/dev/shm has too little room for the large-message settings")
    script = tmp_path / "profile.py"
    script.write_text("import os\nprint(os.environ.get('FASTRTPS_DEFAULT_PROFILES_FILE'))\n")
    env = {key: value for key, value in os.environ.items() if "PROFILES_FILE" not in key}
    env["PYCONNECT_LARGE_MESSAGES"] = "1"
    done = _pyconnect_run(str(script), env=env)
    assert (done.returncode, done.stderr) == (0, "")
    assert large_messages.is_own_profile(done.stdout.strip())


def test_a_profile_of_the_users_own_is_still_left_alone() -> None:
    assert large_messages.is_own_profile("/tmp/pyconnect-fastdds-0123456789ab.xml")
    assert not large_messages.is_own_profile("/home/me/fastdds.xml")
    environ = {"FASTRTPS_DEFAULT_PROFILES_FILE": str(large_messages.write_profile(8 << 20))}
    assert large_messages.disabled_because(environ, default_on=True) is None
    environ = {"FASTRTPS_DEFAULT_PROFILES_FILE": "/home/me/fastdds.xml"}
    assert large_messages.disabled_because(environ, default_on=True) == (
        "FASTRTPS_DEFAULT_PROFILES_FILE is set"
    )
