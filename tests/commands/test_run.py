"""``pyconnect run``: the program gets its own arguments, and the settings without a false alarm."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from pyconnect.ros import large_messages
from tests.commands.processes import ROOT, WAIT
from tests.private_temp import private_temp_dir

__all__ = ["private_temp_dir"]  # an autouse fixture


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


_SHOW_ARGV = "import sys\nprint(sys.argv[1:])\n"


@pytest.mark.parametrize(
    "argv",
    [
        ["-m", "show_argv", "x", "--", "--out", "f"],
        ["-mshow_argv", "x"],
        ["-mshow_argv", "x", "--", "y"],
        ["-m", "show_argv"],
        ["-m", "show_argv", "--"],
        ["show_argv.py", "x", "--", "--out", "f"],
    ],
)
def test_the_program_gets_the_arguments_python_would_give_it(
    tmp_path: Path, argv: list[str]
) -> None:
    """What follows the module (or the script) is the program's exactly as python passes it:
    "--" and all, and after an attached "-mmodule" too."""
    (tmp_path / "show_argv.py").write_text(_SHOW_ARGV)
    env = dict(os.environ, PYCONNECT_LARGE_MESSAGES="0")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(tmp_path), env.get("PYTHONPATH")]))
    expected = subprocess.run(
        [sys.executable, *argv], cwd=tmp_path, capture_output=True, text=True, timeout=WAIT,
        env=env, check=True,
    ).stdout  # fmt: skip
    done = subprocess.run(
        [sys.executable, "-m", "pyconnect.cli", "run", *argv], cwd=tmp_path, capture_output=True,
        text=True, timeout=WAIT, env=env, check=False,
    )  # fmt: skip
    assert (done.returncode, done.stdout) == (0, expected), done.stderr


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


@pytest.mark.parametrize(
    ("value", "setting"),
    [
        ("inf", None),
        ("abc", None),
        ("0", None),
        ("abc", "1"),
        ("1.5", None),  # under the 8 MiB minimum
        ("1.5", "1"),
        ("4096", None),  # above what Fast DDS's 32-bit segment_size holds
        ("5000", "1"),
    ],
)
def test_a_segment_size_that_is_no_size_is_a_usage_error(
    tmp_path: Path, value: str, setting: str | None
) -> None:
    """With PYCONNECT_LARGE_MESSAGES=1 the launcher's own import of pyconnect.ros meets the
    value first: it must not add a second report."""
    script = tmp_path / "ran.py"
    script.write_text("print('ran')\n")
    env = {key: text for key, text in os.environ.items() if "PROFILES_FILE" not in key}
    env.pop("PYCONNECT_LARGE_MESSAGES", None)
    if setting is not None:
        env["PYCONNECT_LARGE_MESSAGES"] = setting
    env["PYCONNECT_SHM_SEGMENT_MB"] = value
    done = _pyconnect_run(str(script), env=env)
    assert (done.returncode, done.stdout, done.stderr) == (
        2,
        "",
        "pyconnect: error: run: PYCONNECT_SHM_SEGMENT_MB: expected a segment size in MiB, "
        f"a number from 8 to 3584 (64 by default), got {value!r}\n",
    )


def test_a_profile_in_the_working_directory_is_the_users_own(tmp_path: Path) -> None:
    """Fast DDS loads DEFAULT_FASTRTPS_PROFILES.xml from the working directory too, and its
    default participant profile wins: pyconnect writes none and says why."""
    (tmp_path / "DEFAULT_FASTRTPS_PROFILES.xml").write_text("<profiles/>\n")
    script = tmp_path / "profile.py"
    script.write_text("import os\nprint(os.environ.get('FASTRTPS_DEFAULT_PROFILES_FILE'))\n")
    env = {key: value for key, value in os.environ.items() if "PROFILES_FILE" not in key}
    env.pop("PYCONNECT_LARGE_MESSAGES", None)
    env.pop("SKIP_DEFAULT_XML_FILE", None)
    done = subprocess.run(
        [sys.executable, "-m", "pyconnect.cli", "run", str(script)], cwd=tmp_path,
        capture_output=True, text=True, timeout=WAIT, env=env, check=False,
    )  # fmt: skip
    assert (done.returncode, done.stdout, done.stderr) == (
        0,
        "None\n",
        "pyconnect run: large-message settings not applied: "
        "DEFAULT_FASTRTPS_PROFILES.xml is in the working directory\n",
    )


def test_off_also_removes_the_settings_a_pyconnect_run_parent_passed_on(tmp_path: Path) -> None:
    """A program under ``pyconnect run`` starts another with PYCONNECT_LARGE_MESSAGES=0: the
    child gets neither pyconnect's profile nor its malloc values, inherited."""
    if large_messages.segment_bytes() < 8 * 1024 * 1024:
        pytest.skip("/dev/shm has too little room for the large-message settings")
    names = [*large_messages.MALLOC_SETTINGS, "FASTRTPS_DEFAULT_PROFILES_FILE"]
    child = tmp_path / "child.py"
    child.write_text(f"import os\nprint([os.environ.get(n) for n in {names!r}])\n")
    parent = tmp_path / "parent.py"
    parent.write_text(
        "import os, subprocess, sys\n"
        "env = dict(os.environ, PYCONNECT_LARGE_MESSAGES='0')\n"
        "print(os.environ['FASTRTPS_DEFAULT_PROFILES_FILE'], flush=True)\n"
        "command = [sys.executable, '-m', 'pyconnect.cli', 'run', sys.argv[1]]\n"
        "sys.exit(subprocess.call(command, env=env))\n"
    )
    env = {
        key: value
        for key, value in os.environ.items()
        if "PROFILES_FILE" not in key and not key.startswith(("MALLOC_", "PYCONNECT_"))
    }
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    done = subprocess.run(
        [sys.executable, "-m", "pyconnect.cli", "run", str(parent), str(child)], cwd=tmp_path,
        capture_output=True, text=True, timeout=WAIT, env=env, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    parent_profile, child_sees = done.stdout.splitlines()
    assert large_messages.is_own_profile(parent_profile)  # the parent had the settings
    assert child_sees == "[None, None, None]"
    assert done.stderr == (
        "pyconnect run: large-message settings not applied: PYCONNECT_LARGE_MESSAGES is off\n"
    )


def _run_closing(stream: str, tmp_path: Path, **extra: str) -> subprocess.CompletedProcess[str]:
    """``pyconnect run`` of a script that leaves a marker, with ``stream`` (1 or 2) closed by
    the shell: python runs a program so, and so must pyconnect run."""
    script = tmp_path / "marker.py"
    script.write_text(
        "import pathlib, sys\n"
        "pathlib.Path(sys.argv[1]).write_text('ran')\n"
        "if sys.stdout is not None:\n"
        "    print('program output')\n"
    )
    command = f'exec "$0" -m pyconnect.cli run "$@" {stream}>&-'
    return subprocess.run(
        ["sh", "-c", command, sys.executable, str(script), str(tmp_path / "marker")],
        cwd=ROOT, capture_output=True, text=True, timeout=WAIT, check=False,
        env=dict(os.environ, **extra),
    )  # fmt: skip


@pytest.mark.parametrize("setting", ["0", "1"])
def test_the_program_runs_with_stdout_closed(tmp_path: Path, setting: str) -> None:
    done = _run_closing("1", tmp_path, PYCONNECT_LARGE_MESSAGES=setting)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "marker").read_text() == "ran"


@pytest.mark.parametrize("setting", ["0", "1"])
def test_the_program_runs_with_stderr_closed_and_its_stdout_is_its_own(
    tmp_path: Path, setting: str
) -> None:
    """The "settings not applied" note (PYCONNECT_LARGE_MESSAGES=0) goes to stderr or nowhere,
    never into the program's stdout."""
    done = _run_closing("2", tmp_path, PYCONNECT_LARGE_MESSAGES=setting)
    assert (done.returncode, done.stdout) == (0, "program output\n")
    assert (tmp_path / "marker").read_text() == "ran"
