"""Large-message set-up: the Fast DDS profile, malloc settings, the opt-out, ``pyconnect run``."""

from __future__ import annotations

import hashlib
import json
import os
import platform
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from pyconnect.commands.common import UsageError
from pyconnect.commands.run import command_line
from pyconnect.ros import large_messages
from tests.private_temp import private_temp_dir

__all__ = ["private_temp_dir"]  # an autouse fixture

MIB = 1024 * 1024


def test_importing_pyconnect_ros_with_the_setting_on_configures_the_process() -> None:
    script = (
        "import os, pyconnect.ros\n"
        "print(open(os.environ['FASTRTPS_DEFAULT_PROFILES_FILE']).read())\n"
    )
    env = {key: value for key, value in os.environ.items() if "PROFILES_FILE" not in key}
    env["PYCONNECT_LARGE_MESSAGES"] = "1"
    text = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=env, check=True,
        timeout=120,
    ).stdout  # fmt: skip
    assert "<type>SHM</type>" in text
    assert f"<segment_size>{large_messages.segment_bytes()}</segment_size>" in text
    assert "<type>UDPv4</type>" in text
    assert "<useBuiltinTransports>false</useBuiltinTransports>" in text


def test_importing_without_the_setting_changes_nothing() -> None:
    assert large_messages.disabled_because({}) == (
        "PYCONNECT_LARGE_MESSAGES is not set (pyconnect run sets it)"
    )


def test_configure_environment_sets_profile_and_malloc_variables() -> None:
    environ: dict[str, str] = {}
    assert large_messages.configure_environment(environ, default_on=True) is None
    assert environ["PYCONNECT_LARGE_MESSAGES"] == "1"
    assert environ["MALLOC_MMAP_THRESHOLD_"] == "268435456"
    assert environ["MALLOC_TRIM_THRESHOLD_"] == "1073741824"
    assert environ["PYCONNECT_MALLOC_SET"] == "MALLOC_MMAP_THRESHOLD_ MALLOC_TRIM_THRESHOLD_"
    assert Path(environ["FASTRTPS_DEFAULT_PROFILES_FILE"]).is_file()
    assert Path(environ["FASTRTPS_DEFAULT_PROFILES_FILE"]).is_absolute()


def test_the_marker_lists_only_the_malloc_variables_pyconnect_set() -> None:
    environ = {"MALLOC_MMAP_THRESHOLD_": "65536"}
    assert large_messages.configure_environment(environ, default_on=True) is None
    assert environ["MALLOC_MMAP_THRESHOLD_"] == "65536"
    assert environ["PYCONNECT_MALLOC_SET"] == "MALLOC_TRIM_THRESHOLD_"
    # Configured again (a child of a pyconnect run program): still pyconnect's, still listed.
    assert large_messages.configure_environment(environ, default_on=True) is None
    assert environ["PYCONNECT_MALLOC_SET"] == "MALLOC_TRIM_THRESHOLD_"


def test_off_removes_what_an_inherited_pyconnect_set_and_nothing_of_the_users() -> None:
    """PYCONNECT_LARGE_MESSAGES=0 in a process whose environment came from a pyconnect run
    program: pyconnect's profile and malloc values go; a user's profile or values stay."""
    inherited: dict[str, str] = {}
    assert large_messages.configure_environment(inherited, default_on=True) is None
    environ = dict(inherited, PYCONNECT_LARGE_MESSAGES="0", OTHER="kept")
    assert large_messages.configure_environment(environ, default_on=True) == (
        "PYCONNECT_LARGE_MESSAGES is off"
    )
    assert environ == {"PYCONNECT_LARGE_MESSAGES": "0", "OTHER": "kept"}
    # A value the user gave since, and a profile of the user's, are the user's.
    environ = dict(inherited, PYCONNECT_LARGE_MESSAGES="off", MALLOC_TRIM_THRESHOLD_="4096")
    environ["FASTDDS_DEFAULT_PROFILES_FILE"] = "/home/me/fastdds.xml"
    assert large_messages.configure_environment(environ) == "PYCONNECT_LARGE_MESSAGES is off"
    assert environ == {
        "PYCONNECT_LARGE_MESSAGES": "off",
        "MALLOC_TRIM_THRESHOLD_": "4096",
        "FASTDDS_DEFAULT_PROFILES_FILE": "/home/me/fastdds.xml",
    }
    # Without the marker the malloc values may be the user's own: they stay.
    environ = dict(large_messages.MALLOC_SETTINGS, PYCONNECT_LARGE_MESSAGES="0")
    assert large_messages.configure_environment(environ) == "PYCONNECT_LARGE_MESSAGES is off"
    assert environ == dict(large_messages.MALLOC_SETTINGS, PYCONNECT_LARGE_MESSAGES="0")


def test_a_profile_in_the_working_directory_is_left_alone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Fast DDS 2.14 loads DEFAULT_FASTRTPS_PROFILES.xml from the working directory (unless
    SKIP_DEFAULT_XML_FILE=1) and its default participant profile wins over pyconnect's."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "DEFAULT_FASTRTPS_PROFILES.xml").write_text("<profiles/>\n")
    environ: dict[str, str] = {}
    assert large_messages.configure_environment(environ, default_on=True) == (
        "DEFAULT_FASTRTPS_PROFILES.xml is in the working directory"
    )
    assert environ == {}
    environ = {"SKIP_DEFAULT_XML_FILE": "1"}
    assert large_messages.configure_environment(environ, default_on=True) is None
    assert large_messages.is_own_profile(environ["FASTRTPS_DEFAULT_PROFILES_FILE"])


@pytest.mark.parametrize(
    ("environ", "reason"),
    [
        ({"PYCONNECT_LARGE_MESSAGES": "0"}, "PYCONNECT_LARGE_MESSAGES is off"),
        ({"PYCONNECT_LARGE_MESSAGES": "off"}, "PYCONNECT_LARGE_MESSAGES is off"),
        ({"FASTRTPS_DEFAULT_PROFILES_FILE": "/mine.xml"}, "FASTRTPS_DEFAULT_PROFILES_FILE is set"),
        ({"FASTDDS_DEFAULT_PROFILES_FILE": "/mine.xml"}, "FASTDDS_DEFAULT_PROFILES_FILE is set"),
        ({"RMW_IMPLEMENTATION": "rmw_zenoh_cpp"}, "RMW_IMPLEMENTATION is rmw_zenoh_cpp"),
    ],
)
def test_settings_are_left_alone_when_turned_off_or_chosen_by_the_user(
    environ: dict[str, str], reason: str
) -> None:
    before = dict(environ)
    assert large_messages.configure_environment(environ, default_on=True) == reason
    assert environ == before


def test_segment_size_follows_the_variable() -> None:
    assert large_messages.segment_bytes({"PYCONNECT_SHM_SEGMENT_MB": "16"}) == 16 * 1024 * 1024


def test_run_command_line() -> None:
    assert command_line(None, ["robot.py", "--fast"]) == [sys.executable, "robot.py", "--fast"]
    assert command_line("examples.demo", []) == [sys.executable, "-m", "examples.demo"]
    with pytest.raises(UsageError) as caught:
        command_line(None, [])
    assert str(caught.value) == "run: give a script (pyconnect run script.py) or -m module"


def _run(tmp_path: Path, **extra: str) -> list[str]:
    script = tmp_path / "show_env.py"
    script.write_text(
        "import os, sys\n"
        "names = ['MALLOC_MMAP_THRESHOLD_', 'MALLOC_TRIM_THRESHOLD_', "
        "'FASTRTPS_DEFAULT_PROFILES_FILE']\n"
        "print(*[str(bool(os.environ.get(n))) for n in names], *sys.argv[1:])\n"
    )
    done = subprocess.run(
        [sys.executable, "-m", "pyconnect.cli", "run", str(script), "a", "--b"],
        capture_output=True, text=True, env=_unconfigured_env(**extra), check=True, timeout=120,
    )  # fmt: skip
    return done.stdout.split()


def _unconfigured_env(**extra: str) -> dict[str, str]:
    """This process's environment without the large-message settings, plus ``extra``."""
    env = {
        key: value
        for key, value in os.environ.items()
        if key not in {"MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_"}
        and "PROFILES_FILE" not in key
        and key != "PYCONNECT_LARGE_MESSAGES"
    }
    env.update(extra)
    return env


def test_pyconnect_run_starts_the_program_with_the_settings(tmp_path: Path) -> None:
    assert _run(tmp_path) == ["True", "True", "True", "a", "--b"]


def test_pyconnect_run_with_the_settings_off_runs_the_program_unchanged(tmp_path: Path) -> None:
    assert _run(tmp_path, PYCONNECT_LARGE_MESSAGES="0") == ["False", "False", "False", "a", "--b"]


def test_pyconnect_run_m_runs_a_module_with_the_settings(tmp_path: Path) -> None:
    """README (Large messages): ``pyconnect run -m module args`` runs the module as
    ``python -m`` would, with the malloc variables and the profile in its environment, and
    every argument after the module (options too) goes to the module."""
    (tmp_path / "robot_vision.py").write_text(
        "import json, os, sys\n"
        "names = ['MALLOC_MMAP_THRESHOLD_', 'MALLOC_TRIM_THRESHOLD_', "
        "'FASTRTPS_DEFAULT_PROFILES_FILE', 'PYCONNECT_LARGE_MESSAGES']\n"
        "print(json.dumps({'name': __name__, 'argv': sys.argv, "
        "'env': {n: os.environ.get(n) for n in names}}))\n"
    )
    path = os.pathsep.join(filter(None, [str(tmp_path), os.environ.get("PYTHONPATH")]))
    done = subprocess.run(
        [sys.executable, "-m", "pyconnect.cli", "run", "-m", "robot_vision", "a", "--b"],
        capture_output=True, text=True, env=_unconfigured_env(PYTHONPATH=path), timeout=120,
        check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    seen = json.loads(done.stdout)
    assert seen["name"] == "__main__"
    assert seen["argv"] == [str(tmp_path / "robot_vision.py"), "a", "--b"]
    env = seen["env"]
    assert env["MALLOC_MMAP_THRESHOLD_"] == large_messages.MALLOC_SETTINGS["MALLOC_MMAP_THRESHOLD_"]
    assert env["MALLOC_TRIM_THRESHOLD_"] == large_messages.MALLOC_SETTINGS["MALLOC_TRIM_THRESHOLD_"]
    assert large_messages.is_own_profile(env["FASTRTPS_DEFAULT_PROFILES_FILE"])
    assert Path(env["FASTRTPS_DEFAULT_PROFILES_FILE"]).is_file()
    assert env["PYCONNECT_LARGE_MESSAGES"] == "1"


_PEER = """
import os, sys, time
import pyconnect.ros  # configures Fast DDS (PYCONNECT_LARGE_MESSAGES=1) before the node
import rclpy
from sensor_msgs.msg import Image

assert os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"].endswith(".xml")
rclpy.init()
node = rclpy.create_node("large_" + sys.argv[1])
if sys.argv[1] == "pub":
    publisher = node.create_publisher(Image, "large_profile_check", 5)
    image = Image(height=600, width=800, encoding="rgb8", step=2400)
    image.data.frombytes(bytes(range(256)) * 5625)  # 1.44 MB: fragments through SHM
    while True:  # until the test ends this process
        publisher.publish(image)
        rclpy.spin_once(node, timeout_sec=0.05)
else:
    got = []
    node.create_subscription(Image, "large_profile_check", got.append, 5)
    while not got:
        rclpy.spin_once(node, timeout_sec=0.1)
    data = bytes(got[0].data)
    print("GOT", len(data), data == bytes(range(256)) * 5625, flush=True)
    node.destroy_node()
    rclpy.shutdown()
"""


@pytest.mark.parametrize("discovery_range", ["LOCALHOST", None])
def test_two_processes_talk_with_the_profile_on(discovery_range: str | None) -> None:
    """With pyconnect's profile in both processes, a 1.44 MB image goes from one to the other,
    with LOCALHOST discovery (the tests') and Fast DDS's default (rmw adds its own transports
    for LOCALHOST: the profile must not stop discovery either way)."""
    env = {key: value for key, value in os.environ.items() if "PROFILES_FILE" not in key}
    env["PYCONNECT_LARGE_MESSAGES"] = "1"
    env.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)
    if discovery_range is not None:
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = discovery_range
    receiver = subprocess.Popen(
        [sys.executable, "-c", _PEER, "sub"], stdout=subprocess.PIPE, text=True, env=env
    )
    sender = subprocess.Popen(
        [sys.executable, "-c", _PEER, "pub"], stdout=subprocess.DEVNULL, env=env
    )
    try:
        out, _ = receiver.communicate(timeout=120)
    finally:
        sender.terminate()  # SIGTERM: rclpy's handler shuts the context down cleanly
        try:
            sender.wait(30)
        except subprocess.TimeoutExpired:
            sender.kill()
            sender.wait()
        if receiver.poll() is None:
            receiver.kill()
            receiver.wait()
    assert out.split() == ["GOT", "1440000", "True"]


def test_the_segment_shrinks_to_a_quarter_of_what_dev_shm_can_hold(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """README (Large messages): the 64 MiB segment is shrunk to a quarter of what /dev/shm can
    hold (a small container's), and the profile written has that size."""
    import shutil
    from types import SimpleNamespace

    free = 100 * 1024 * 1024  # a quarter is 25 MiB: less than the 64 MiB default
    asked: list[str] = []

    def disk_usage(path: str) -> SimpleNamespace:
        asked.append(str(path))
        return SimpleNamespace(total=4 * free, used=3 * free, free=free)

    monkeypatch.setattr(shutil, "disk_usage", disk_usage)
    assert large_messages.segment_bytes({}) == free // 4
    assert asked == ["/dev/shm"]
    # The largest segment is the limit wherever /dev/shm is vast.
    free = 100 * 1024 * MIB
    assert large_messages.segment_bytes({"PYCONNECT_SHM_SEGMENT_MB": "3584"}) == 3584 * MIB
    free = 100 * MIB
    # A smaller wish is kept as it is.
    assert large_messages.segment_bytes({"PYCONNECT_SHM_SEGMENT_MB": "16"}) == 16 * 1024 * 1024
    environ: dict[str, str] = {}
    assert large_messages.configure_environment(environ, default_on=True) is None
    profile = Path(environ["FASTRTPS_DEFAULT_PROFILES_FILE"]).read_text()
    assert f"<segment_size>{free // 4}</segment_size>" in profile


def _profile_name(segment: int) -> str:
    digest = hashlib.sha256(large_messages.profile_xml(segment).encode()).hexdigest()[:12]
    return f"pyconnect-fastdds-{digest}.xml"


def test_the_profile_goes_to_a_directory_only_the_user_can_enter(private_temp_dir: Path) -> None:
    path = large_messages.write_profile(16 * MIB)
    assert path.parent == private_temp_dir / f"pyconnect-{os.getuid()}"
    status = os.lstat(path.parent)
    assert stat.S_ISDIR(status.st_mode)
    assert (status.st_uid, stat.S_IMODE(status.st_mode)) == (os.getuid(), 0o700)
    assert path.read_text() == large_messages.profile_xml(16 * MIB)


def test_a_profile_planted_in_the_temp_directory_is_not_used(private_temp_dir: Path) -> None:
    """The temp directory is world-writable: a file at the profile's name there is another
    user's, and would choose this user's DDS transports."""
    planted = private_temp_dir / _profile_name(16 * MIB)
    planted.write_text("<profiles><!-- someone else's --></profiles>\n")
    path = large_messages.write_profile(16 * MIB)
    assert path != planted
    assert path.read_text() == large_messages.profile_xml(16 * MIB)
    assert planted.read_text() == "<profiles><!-- someone else's --></profiles>\n"


def test_a_link_planted_at_the_partial_files_name_is_not_followed(private_temp_dir: Path) -> None:
    victim = private_temp_dir / "victim.txt"
    victim.write_text("precious\n")
    partial = _profile_name(16 * MIB).replace(".xml", f".{os.getpid()}.tmp")
    (private_temp_dir / partial).symlink_to(victim)
    path = large_messages.write_profile(16 * MIB)
    assert victim.read_text() == "precious\n"
    assert not path.is_symlink()
    assert path.read_text() == large_messages.profile_xml(16 * MIB)


def test_a_profile_with_other_content_is_written_again() -> None:
    path = large_messages.write_profile(16 * MIB)
    path.write_text("<profiles/>\n")
    assert large_messages.write_profile(16 * MIB) == path
    assert path.read_text() == large_messages.profile_xml(16 * MIB)
    assert [entry.name for entry in path.parent.iterdir()] == [path.name]  # no partial left


@pytest.mark.parametrize("taken_by", ["open directory", "symlink", "file", "other user"])
def test_a_private_directory_name_taken_by_something_else_is_refused(
    private_temp_dir: Path, taken_by: str
) -> None:
    name = private_temp_dir / f"pyconnect-{os.getuid()}"
    if taken_by == "open directory":
        name.mkdir()
        name.chmod(0o777)
        problem = "has mode 777, expected 700"
    elif taken_by == "symlink":
        (private_temp_dir / "elsewhere").mkdir(mode=0o700)
        name.symlink_to(private_temp_dir / "elsewhere")
        problem = "is not a directory"
    elif taken_by == "file":
        name.write_text("")
        problem = "is not a directory"
    else:
        if os.getuid() != 0:
            pytest.skip("only root can give a directory to another user")
        name.mkdir(mode=0o700)
        os.chown(name, 12345, -1)
        problem = f"belongs to user 12345, expected {os.getuid()}"
    environ: dict[str, str] = {}
    assert large_messages.configure_environment(environ, default_on=True) == (
        f"the Fast DDS profile could not be written: {name} {problem}, "
        "so it cannot hold pyconnect's profile"
    )
    assert environ == {}
    assert sorted(entry.name for entry in private_temp_dir.iterdir()) == sorted(
        {name.name, "elsewhere"} if taken_by == "symlink" else {name.name}
    )


def test_a_relative_xdg_runtime_dir_is_ignored_and_the_path_is_absolute(
    private_temp_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The XDG spec says to ignore a relative XDG_RUNTIME_DIR; a relative profile path would
    name another file once the program changes directory."""
    (tmp_path / "run").mkdir(mode=0o700)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_RUNTIME_DIR", "run")
    path = large_messages.write_profile(16 * MIB)
    assert path.parent == private_temp_dir / f"pyconnect-{os.getuid()}"
    # A relative temp directory too (gettempdir() keeps TMPDIR=. as ".").
    monkeypatch.chdir(private_temp_dir)
    monkeypatch.setattr(large_messages.tempfile, "gettempdir", lambda: ".")
    assert large_messages.write_profile(16 * MIB) == path


def test_the_profile_goes_to_xdg_runtime_dir_only_when_it_is_private(
    private_temp_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    runtime = tmp_path / "run"
    runtime.mkdir(mode=0o700)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(runtime))
    assert large_messages.write_profile(16 * MIB).parent == runtime
    runtime.chmod(0o755)
    fallback = private_temp_dir / f"pyconnect-{os.getuid()}"
    assert large_messages.write_profile(16 * MIB).parent == fallback


_BAD_SEGMENT = (
    "PYCONNECT_SHM_SEGMENT_MB: expected a segment size in MiB, a number from 8 to 3584 "
    "(64 by default), got {!r}"
)


@pytest.mark.parametrize(
    "value",
    [
        *["inf", "-inf", "nan", "1e400", "abc", "0", "-16", "16 MiB"],
        *["1.5", "7.99"],  # under the 8 MiB minimum
        # Fast DDS reads segment_size as 32 bits (4096 wraps to 0, 5000 to 904 MiB) and adds
        # its bookkeeping (4000 fails to allocate).
        *["3584.5", "4000", "4096", "5000", "1e308"],
    ],
)
def test_a_segment_size_that_is_no_size_is_an_error_naming_the_variable(value: str) -> None:
    with pytest.raises(large_messages.SegmentSizeError) as caught:
        large_messages.segment_bytes({"PYCONNECT_SHM_SEGMENT_MB": value})
    assert str(caught.value) == _BAD_SEGMENT.format(value)
    environ = {"PYCONNECT_SHM_SEGMENT_MB": value}
    with pytest.raises(large_messages.SegmentSizeError):
        large_messages.configure_environment(environ, default_on=True)
    assert environ == {"PYCONNECT_SHM_SEGMENT_MB": value}


def test_an_empty_segment_size_is_the_default_and_the_limits_are_sizes() -> None:
    assert large_messages.segment_bytes({"PYCONNECT_SHM_SEGMENT_MB": ""}) == (
        large_messages.segment_bytes({})
    )
    assert large_messages.wanted_segment_bytes({"PYCONNECT_SHM_SEGMENT_MB": "8"}) == 8 * MIB
    assert large_messages.wanted_segment_bytes({"PYCONNECT_SHM_SEGMENT_MB": "3584"}) == (3584 * MIB)
    # Written in 32 bits with Fast DDS's bookkeeping (under 5 %), it stays below 2**32.
    assert 3584 * MIB * 1.05 < 2**32


@pytest.mark.parametrize("value", ["abc", "1.5", "5000"])
def test_importing_with_a_bad_segment_size_warns_and_changes_nothing(value: str) -> None:
    script = (
        "import os, pyconnect.ros\n"
        "print(sorted(n for n in os.environ if n.startswith(('FAST', 'MALLOC'))))\n"
    )
    env = _unconfigured_env(PYCONNECT_LARGE_MESSAGES="1", PYCONNECT_SHM_SEGMENT_MB=value)
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=120,
        check=False,
    )  # fmt: skip
    assert (done.returncode, done.stdout) == (0, "[]\n")
    warning = f"large-message settings not applied: {_BAD_SEGMENT.format(value)}\n"
    assert done.stderr == warning


_MMAPPED = """
import ctypes, ctypes.util, os, sys
libc = ctypes.CDLL(ctypes.util.find_library("c"))
libc.malloc.restype = ctypes.c_void_p
libc.malloc.argtypes = [ctypes.c_size_t]
libc.free.argtypes = [ctypes.c_void_p]

def mmapped() -> bool:
    # glibc returns a chunk of its own mapping 16 bytes into a fresh page
    blocks = [libc.malloc(200_000) for _ in range(20)]
    answer = all(block % 4096 == 16 for block in blocks)
    for block in blocks:
        libc.free(block)
    return answer

before = mmapped()
import pyconnect.ros
print(before, mmapped(), os.environ["MALLOC_MMAP_THRESHOLD_"])
"""


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="mallopt is glibc's")
def test_importing_keeps_the_users_own_malloc_setting() -> None:
    """The user's MALLOC_MMAP_THRESHOLD_ (64 KiB: a 200 kB block is mapped) stays in force
    when only MALLOC_TRIM_THRESHOLD_ is left to pyconnect."""
    env = _unconfigured_env(PYCONNECT_LARGE_MESSAGES="1", MALLOC_MMAP_THRESHOLD_="65536")
    done = subprocess.run(
        [sys.executable, "-c", _MMAPPED], capture_output=True, text=True, env=env, timeout=120,
        check=True,
    )  # fmt: skip
    assert done.stdout.split() == ["True", "True", "65536"]
    # Without the user's setting, pyconnect's own (256 MiB, or 32 MiB) keeps it on the heap.
    env = _unconfigured_env(PYCONNECT_LARGE_MESSAGES="1")
    done = subprocess.run(
        [sys.executable, "-c", _MMAPPED], capture_output=True, text=True, env=env, timeout=120,
        check=True,
    )  # fmt: skip
    assert done.stdout.split() == ["True", "False", "268435456"]


def test_an_empty_rmw_implementation_is_the_default_fast_dds() -> None:
    """rclpy loads rmw_fastrtps_cpp when RMW_IMPLEMENTATION is empty."""
    environ = {"RMW_IMPLEMENTATION": ""}
    assert large_messages.configure_environment(environ, default_on=True) is None
    assert large_messages.is_own_profile(environ["FASTRTPS_DEFAULT_PROFILES_FILE"])
