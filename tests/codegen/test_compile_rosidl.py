"""Rebuilt from their shipped definitions, installed packages come out as the wheels ship them.

``test_msgs`` and ``geometry_msgs`` (every corner type) go through the adapter and the type
description generator: each JSON, RIHS01 hashes included, equals the installed one. ``std_srvs``
is compiled in full into a temporary prefix: its type descriptions equal the installed ones, and
messages serialized by the rebuilt type support read back with the installed one, and back.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from rclpy.serialization import deserialize_message, serialize_message
from std_srvs.srv import SetBool, Trigger

from pyconnect.codegen.cli import main
from pyconnect.codegen.compile_generate import adapt_interfaces, describe_types
from pyconnect.codegen.compile_install import InstallLayout
from pyconnect.codegen.compile_package import resolve_dependencies
from pyconnect.codegen.package_order import referenced_packages
from pyconnect.typesys.loading import load_packages
from pyconnect.typesys.packages import folder_interface_files, installed_packages
from tests.codegen.test_compile import TIMEOUT, bare_environment

# Serialized by the rebuilt std_srvs in a bare process; printed as hex, one line each.
_SERIALIZE = """
import sys
import std_srvs
from rclpy.serialization import serialize_message
from std_srvs.srv import SetBool, Trigger
print("SETBOOL", serialize_message(SetBool.Request(data=True)).hex())
print("TRIGGER", serialize_message(Trigger.Response(success=True, message="rebuilt")).hex())
print("MODULE", std_srvs.__file__)
maps = open("/proc/self/maps").read().splitlines()
print("LIBRARY", *sorted({l.split()[-1] for l in maps if "libstd_srvs__rosidl_typesupport_" in l}))
"""


def installed_json(package: str, relative: Path) -> object:
    return json.loads((installed_packages()[package].share / relative).read_text())


@pytest.mark.parametrize("package", ["test_msgs", "geometry_msgs"])
def test_type_descriptions_equal_the_installed_ones(package: str, tmp_path: Path) -> None:
    share = installed_packages()[package].share
    requested, types = load_packages(folders=[share])
    dependencies = resolve_dependencies(referenced_packages(requested[package], types))
    files = folder_interface_files(share)
    idl_files = adapt_interfaces(package, share, files, tmp_path)
    out = describe_types(
        package=package, build=tmp_path, idl_files=idl_files, dependencies=dependencies
    )
    assert len(idl_files) == len(files) > 10
    for relative in idl_files:
        json_file = Path(relative).with_suffix(".json")
        assert json.loads((out / json_file).read_text()) == installed_json(package, json_file)


@pytest.fixture(scope="module")
def rebuilt_std_srvs(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    prefix = tmp_path_factory.mktemp("std_srvs")
    share = installed_packages()["std_srvs"].share
    assert main(["build", "--compile", str(share), "--prefix", str(prefix)]) == 0
    yield prefix


def test_rebuilt_type_descriptions_equal_the_installed_ones(rebuilt_std_srvs: Path) -> None:
    share = InstallLayout.for_prefix(rebuilt_std_srvs).share / "std_srvs"
    rebuilt = sorted(p.relative_to(share) for p in share.rglob("*.json"))
    assert [p.as_posix() for p in rebuilt] == [
        "srv/Empty.json",
        "srv/SetBool.json",
        "srv/Trigger.json",
    ]
    for relative in rebuilt:
        assert json.loads((share / relative).read_text()) == installed_json("std_srvs", relative)


def test_rebuilt_wire_bytes_read_back_with_the_installed_ones(rebuilt_std_srvs: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-c", _SERIALIZE],
        env=bare_environment(rebuilt_std_srvs),
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        check=False,
    )
    lines = dict(line.split(" ", 1) for line in result.stdout.splitlines())
    assert lines.keys() == {"MODULE", "LIBRARY", "SETBOOL", "TRIGGER"}, result.stderr
    assert Path(lines["MODULE"]).is_relative_to(rebuilt_std_srvs)
    # Every std_srvs type support library in the process is the rebuilt one.
    libraries = lines["LIBRARY"].split()
    assert [Path(p).name for p in libraries] == [
        "libstd_srvs__rosidl_typesupport_c.so",
        "libstd_srvs__rosidl_typesupport_fastrtps_c.so",
        "libstd_srvs__rosidl_typesupport_introspection_c.so",
    ]
    assert all(Path(p).is_relative_to(rebuilt_std_srvs) for p in libraries)
    set_bool = SetBool.Request(data=True)
    trigger = Trigger.Response(success=True, message="rebuilt")
    for key, msg in (("SETBOOL", set_bool), ("TRIGGER", trigger)):
        wire = bytes.fromhex(lines[key])
        assert deserialize_message(wire, type(msg)) == msg
        assert len(wire) == len(serialize_message(msg))
