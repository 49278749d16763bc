"""codecgen build --compile: the installed layout, imports in a bare process, no-op rebuilds, errors."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest
from rclpy.serialization import deserialize_message, serialize_message

from pyconnect import codecs
from pyconnect.codegen.cli import main
from pyconnect.codegen.compile_install import InstallLayout, installed_record
from pyconnect.typesys.loading import load_packages
from tests.codegen.conftest import EXTRAS, TUTORIAL

PEER = Path(__file__).with_name("compiled_peer.py")
TIMEOUT = 60.0


def bare_environment(prefix: Path) -> dict[str, str]:
    """What a fresh shell has: no ROS or pyconnect variables; PYTHONPATH only for a --prefix."""
    environment = {
        "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
        "HOME": os.environ.get("HOME", "/tmp"),
        "ROS_DOMAIN_ID": os.environ["ROS_DOMAIN_ID"],
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "PYTHONUNBUFFERED": "1",
    }
    if prefix != Path(sys.prefix):
        environment["PYTHONPATH"] = str(InstallLayout.for_prefix(prefix).python)
    return environment


def test_layout_is_what_colcon_installs(compiled_prefix: Path) -> None:
    layout = InstallLayout.for_prefix(compiled_prefix)
    index = layout.resource_index
    assert (index / "rosidl_interfaces" / "tutorial_interfaces").read_text().split() == [
        "action/MoveTo.action", "action/MoveTo.idl", "msg/Num.idl", "msg/Num.msg",
        "msg/Sphere.idl", "msg/Sphere.msg", "srv/AddThreeInts.idl", "srv/AddThreeInts.srv",
    ]  # fmt: skip
    assert (index / "packages" / "tutorial_interfaces").is_file()
    assert (index / "package_run_dependencies" / "tutorial_extras").read_text().split(";") == [
        "builtin_interfaces", "geometry_msgs", "std_msgs", "tutorial_interfaces",
    ]  # fmt: skip
    share = layout.share / "tutorial_interfaces"
    for name in ("msg/Num", "srv/AddThreeInts", "action/MoveTo"):
        assert (share / f"{name}.idl").is_file()
        assert json.loads((share / f"{name}.json").read_text())["type_hashes"]
    assert (share / "msg/Num.msg").read_text() == (TUTORIAL / "msg/Num.msg").read_text()
    assert (share / "package.xml").read_text() == (TUTORIAL / "package.xml").read_text()
    generators = ("rosidl_generator_c", "rosidl_typesupport_fastrtps_c",
                  "rosidl_typesupport_introspection_c", "rosidl_typesupport_c",
                  "rosidl_generator_py")  # fmt: skip
    for generator in generators:
        assert (layout.lib / f"libtutorial_interfaces__{generator}.so").is_file()
    headers = layout.include / "tutorial_interfaces" / "tutorial_interfaces" / "msg"
    assert (headers / "num.h").is_file() and (headers / "detail" / "num__struct.h").is_file()
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    python = layout.python / "tutorial_interfaces"
    assert (python / f"tutorial_interfaces_s__rosidl_typesupport_c{suffix}").is_file()
    assert sorted(p.name for p in python.glob("*/_[a-z]*.py")) == [
        "_add_three_ints.py",
        "_move_to.py",
        "_num.py",
        "_sphere.py",
    ]
    assert not list(compiled_prefix.glob(".codecgen-*")), "the build folder is removed"
    # The dist-info RECORD lists every file, so `pip uninstall tutorial_interfaces` removes all.
    record = (layout.python / "tutorial_interfaces-0.1.0.dist-info" / "RECORD").read_text()
    recorded = {os.path.normpath(layout.python / line.split(",")[0]) for line in record.split()}
    on_disk = {
        os.path.normpath(p)
        for root in (python, share, headers.parent.parent)
        for p in root.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    }
    assert on_disk <= recorded


def test_default_prefix_is_the_active_environment() -> None:
    layout = InstallLayout.for_prefix(None)
    assert layout.prefix == Path(sys.prefix)
    assert str(layout.python) in sys.path


def test_rclpy_in_a_bare_process_accepts_the_types(compiled_prefix: Path) -> None:
    """Publishers, subscriptions, services, clients and actions; no LD_LIBRARY_PATH needed."""
    result = subprocess.run(
        [sys.executable, str(PEER), "check"],
        env=bare_environment(compiled_prefix),
        capture_output=True,
        text=True,
        timeout=TIMEOUT * 2,
        check=False,
    )
    assert result.stdout.splitlines()[:1] == ["READY 7 tutorial_interfaces.msg._num"], result.stderr


def test_hashes_equal_what_pyconnect_computes(compiled_prefix: Path) -> None:
    """rosidl's JSON written at build time and the type model agree on every RIHS01 hash."""
    share = InstallLayout.for_prefix(compiled_prefix).share
    requested, types = load_packages(folders=[TUTORIAL, EXTRAS])
    hashes = {name: msg.type_hash for name, msg in types.messages.items()}
    for package in requested.values():
        hashes.update({i.full_name: i.type_hash for i in (*package.services, *package.actions)})
    checked = 0
    for package_name in ("tutorial_interfaces", "tutorial_extras"):
        for path in (share / package_name).rglob("*.json"):
            for entry in json.loads(path.read_text())["type_hashes"]:
                # The implicit action services (MoveTo_GetResult, ...) are not in the model.
                if entry["type_name"] in hashes:
                    assert hashes[entry["type_name"]] == entry["hash_string"]
                    checked += 1
    assert checked > 20


def test_the_registry_uses_the_generated_codecs(compiled_prefix: Path) -> None:
    import pyconnect_generated.tutorial_extras.dict_codecs as extras_codecs
    from pyconnect_generated.tutorial_interfaces.typed_dicts import SphereDict
    from tutorial_extras.msg import NumList
    from tutorial_interfaces.msg import Num, Sphere

    codec = codecs.default_registry.lookup_dict(NumList)
    assert codec.to_dict.__module__ == extras_codecs.__name__
    assert Path(extras_codecs.__file__).is_relative_to(compiled_prefix)
    assert list(SphereDict.__annotations__) == ["header", "center", "radius"]
    value = {"label": "two", "nums": [{"num": 1}, {"num": -2}], "spheres": []}
    msg = codecs.from_dict(value, "tutorial_extras/NumList")
    assert msg == NumList(label="two", nums=[Num(num=1), Num(num=-2)])
    assert codecs.to_dict(msg) == value
    sphere = Sphere(radius=2.5)
    sphere.center.x = 1.0
    wire = serialize_message(sphere)
    assert codecs.wire.decode(wire, "tutorial_interfaces/msg/Sphere") == codecs.to_dict(sphere)
    encoded = codecs.wire.encode(codecs.to_dict(sphere), "tutorial_interfaces/msg/Sphere")
    assert deserialize_message(encoded, Sphere) == sphere
    service = codecs.lookup("tutorial_interfaces/srv/AddThreeInts")
    assert service.request.encode({"a": 1, "b": 2, "c": 3}).c == 3  # type: ignore[union-attr]


def test_unchanged_input_is_a_no_op(
    compiled_prefix: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    layout = InstallLayout.for_prefix(compiled_prefix)
    library = layout.lib / "libtutorial_interfaces__rosidl_generator_c.so"
    before = library.stat().st_mtime_ns
    argv = ["build", "--compile", str(TUTORIAL)]  # the active environment, as installed
    assert main(argv) == 0
    assert capsys.readouterr().out == (
        f"codecgen: tutorial_interfaces: up to date ({layout.python / 'tutorial_interfaces'})\n"
    )
    assert library.stat().st_mtime_ns == before


def snapshot(prefix: Path) -> dict[Path, int]:
    """Every file of the compiled tutorial_interfaces install, with its modification time."""
    files = installed_record(InstallLayout.for_prefix(prefix), "tutorial_interfaces")
    assert len(files) > 40
    return {path: path.stat().st_mtime_ns for path in files}


def test_a_changed_msg_rebuilds_and_a_failed_build_changes_nothing(
    compiled_prefix: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A changed .msg is rebuilt; when that build fails, the previous install stays as it was."""
    changed = tmp_path / "tutorial_interfaces"
    shutil.copytree(TUTORIAL, changed)
    (changed / "msg" / "Num.msg").write_text("int64 num\nstring label\n")
    layout = InstallLayout.for_prefix(compiled_prefix)
    installed = snapshot(compiled_prefix)
    monkeypatch.setenv("CC", "false")  # a compiler that always fails
    argv = ["build", "--compile", str(changed), "--prefix", str(compiled_prefix)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("codecgen: compiling libtutorial_interfaces__rosidl_generator_c.so")
    assert err.count("\n") == 1
    assert snapshot(compiled_prefix) == installed
    assert not list(compiled_prefix.glob(".codecgen-*")), "the build folder is removed"
    num = layout.python / "tutorial_interfaces" / "msg" / "_num.py"
    assert "label" not in num.read_text()


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("int65 num\n", "msg/Num.msg:1: unknown type 'int65'"),
        ("int64 num\nint64 num\n", "msg/Num.msg:2: "),
        ("int64 num\nnot_a_pkg/Thing thing\n",
         "msg/Num.msg:2: tutorial_interfaces/msg/Num: unknown type not_a_pkg/msg/Thing "
         "(is its package installed?)"),
    ],
)  # fmt: skip
def test_bad_input_is_one_line_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, expected: str
) -> None:
    folder = tmp_path / "tutorial_interfaces"
    shutil.copytree(TUTORIAL, folder)
    (folder / "msg" / "Num.msg").write_text(text)
    prefix = tmp_path / "prefix"
    assert main(["build", "--compile", str(folder), "--prefix", str(prefix)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"codecgen: {folder / expected}")
    assert err.count("\n") == 1
    assert not prefix.exists(), "nothing is written for bad input"


def test_a_missing_compiler_says_what_to_install(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    prefix = tmp_path / "prefix"
    assert main(["build", "--compile", str(TUTORIAL), "--prefix", str(prefix)]) == 2
    assert capsys.readouterr().err == (
        "codecgen: no C compiler found: install one (Debian/Ubuntu: `sudo apt install "
        "build-essential`; Fedora: `sudo dnf install gcc gcc-c++`) or set CC/CXX\n"
    )
    assert not (prefix / "lib").exists()


def _files(root: Path) -> set[str]:
    return {
        p.relative_to(root).as_posix()
        for p in root.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    }


def _copy_of(prefix: Path, target: Path) -> Path:
    """The two compiled packages' files (from their RECORDs) copied to a prefix of their own."""
    layout = InstallLayout.for_prefix(prefix)
    for package in ("tutorial_interfaces", "tutorial_extras"):
        for path in installed_record(layout, package):
            copy = target / path.relative_to(prefix)
            copy.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, copy)
    return target


def test_codecgen_uninstall_removes_every_file(compiled_prefix: Path, tmp_path: Path) -> None:
    prefix = _copy_of(compiled_prefix, tmp_path / "prefix")
    extras_only = {f for f in _files(prefix) if "tutorial_interfaces" not in f}
    assert main(["uninstall", "tutorial_interfaces", "--prefix", str(prefix)]) == 0
    assert _files(prefix) == extras_only
    assert not (InstallLayout.for_prefix(prefix).python / "tutorial_interfaces").exists()
    assert main(["uninstall", "tutorial_interfaces", "--prefix", str(prefix)]) == 1


def test_pip_uninstall_removes_every_file(compiled_prefix: Path, tmp_path: Path) -> None:
    """The packages copied into an environment of their own (a venv): pip reads the RECORD."""
    prefix = _copy_of(compiled_prefix, tmp_path / "env")
    before = _files(prefix)
    extras_only = {f for f in before if "tutorial_interfaces" not in f}
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(prefix)], check=True)
    venv_files = _files(prefix) - before
    pip = [sys.executable, "-m", "pip", "--python", str(prefix / "bin" / "python")]
    result = subprocess.run(
        [*pip, "uninstall", "-y", "tutorial_interfaces"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert "Successfully uninstalled tutorial_interfaces-0.1.0" in result.stdout, result.stderr
    assert _files(prefix) == extras_only | venv_files


def test_missing_ros_headers_say_what_to_install(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import pyconnect.codegen.compile_toolchain as toolchain

    monkeypatch.setattr(toolchain, "ament_prefixes", lambda: [])  # a ROS install without include/
    prefix = tmp_path / "prefix"
    assert main(["build", "--compile", str(TUTORIAL), "--prefix", str(prefix)]) == 2
    assert capsys.readouterr().err == (
        f"codecgen: header rosidl_runtime_c/message_type_support_struct.h not found under "
        f"{prefix.resolve()}: install ROS 2 from the wheels (`pip install "
        "'ros-jazzy-rclpy[fastrtps]'`) or source a ROS 2 Jazzy install\n"
    )


def test_a_prefix_on_sys_path_is_searched(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """PYTHONPATH=PREFIX/lib/python3.X/site-packages is all a --prefix install needs."""
    from pyconnect.codecs.search_path import codec_folders
    from pyconnect.typesys.packages import ament_prefixes

    layout = InstallLayout.for_prefix(tmp_path)
    (layout.resource_index / "rosidl_interfaces").mkdir(parents=True)
    (layout.python / "pyconnect_codecs" / "pyconnect_generated").mkdir(parents=True)
    monkeypatch.setattr(sys, "path", [*sys.path, str(layout.python)])
    assert ament_prefixes()[-1] == tmp_path
    assert codec_folders()[-1] == str(layout.python / "pyconnect_codecs" / "pyconnect_generated")


def test_a_changed_msg_is_rebuilt(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A one-message package: built, unchanged (no-op), changed (rebuilt with the new field)."""
    folder = tmp_path / "tiny_msgs"
    (folder / "msg").mkdir(parents=True)
    (folder / "msg" / "Flag.msg").write_text("bool on\n")
    prefix = tmp_path / "prefix"
    argv = ["build", "--compile", str(folder), "--prefix", str(prefix)]
    statuses: list[str] = []
    for text in (None, "bool on\nstring why\n"):
        if text is not None:
            (folder / "msg" / "Flag.msg").write_text(text)
        assert main(argv) == 0
        assert main(argv) == 0
        out = capsys.readouterr().out
        statuses += [line.split(" (")[0].rsplit(": ", 1)[1] for line in out.splitlines()]
    assert statuses == ["built", "up to date", "built", "up to date"]
    script = "from tiny_msgs.msg import Flag; print(Flag(on=True, why='changed'))"
    result = subprocess.run(
        [sys.executable, "-c", script],
        env=bare_environment(prefix),
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        check=False,
    )
    assert result.stdout == "tiny_msgs.msg.Flag(on=True, why='changed')\n", result.stderr
