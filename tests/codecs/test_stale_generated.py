"""Generated wire code made from another version of a type than the installed one is not used.

A folder on the codec search path generated before a package changed (or ``generated/`` against
a sourced install of another ROS version) would read and write the old fields: the registry
compares its RIHS01 hash with the installed one and compiles the installed type instead.
"""

from __future__ import annotations

import shutil
import sys
from collections.abc import Iterator
from pathlib import Path

import pyconnect_generated
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from rmw_dds_common.msg import Gid, NodeEntitiesInfo

from pyconnect.codecs import Registry, search_path
from pyconnect.codecs.type_code import generated_wire_code
from pyconnect.codegen.cli import main
from pyconnect.typesys.packages import installed_packages, installed_type_hash

PACKAGE = "rmw_dds_common"  # installed with the wheels, not one of generated/'s packages


@pytest.fixture
def codec_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """An out folder on the codec search path; the search path and modules restored after."""
    saved = list(pyconnect_generated.__path__)
    out = tmp_path / "out"
    monkeypatch.setenv(search_path.ENV_VAR, str(out))
    yield out
    pyconnect_generated.__path__[:] = saved
    for name in [m for m in sys.modules if m.startswith(f"pyconnect_generated.{PACKAGE}")]:
        del sys.modules[name]


def _build_from(folder: Path, out: Path) -> None:
    assert main(["build", "--from", str(folder), "--out", str(out)]) == 0
    search_path.refresh()


def test_stale_generated_wire_code_falls_back_to_the_installed_type(
    tmp_path: Path, codec_path: Path
) -> None:
    # The package as it was before a field was added: generated into the out folder.
    folder = tmp_path / PACKAGE
    shutil.copytree(installed_packages()[PACKAGE].share / "msg", folder / "msg")
    (folder / "msg" / "Gid.msg").write_text("char[16] data\nuint16 added 9\n")
    _build_from(folder, codec_path)
    for name in (f"{PACKAGE}/msg/Gid", f"{PACKAGE}/msg/NodeEntitiesInfo"):  # Gid and one nesting it
        assert generated_wire_code(name) is None, name
    codec = Registry().wire_codec(f"{PACKAGE}/msg/Gid")
    assert codec.type_hash == installed_type_hash(f"{PACKAGE}/msg/Gid")
    msg = Gid(data=list(range(16)))
    assert codec.to_dict(serialize_message(msg)) == {"data": bytes(range(16))}
    assert deserialize_message(codec.from_dict({"data": bytes(range(16))}), Gid) == msg
    info = NodeEntitiesInfo(node_name="n", reader_gid_seq=[msg])
    nested = Registry().wire_codec(f"{PACKAGE}/msg/NodeEntitiesInfo")
    assert deserialize_message(nested.from_dict(nested.to_dict(serialize_message(info))),
                               NodeEntitiesInfo) == info  # fmt: skip


def test_current_generated_wire_code_is_used(tmp_path: Path, codec_path: Path) -> None:
    folder = tmp_path / PACKAGE
    shutil.copytree(installed_packages()[PACKAGE].share / "msg", folder / "msg")
    _build_from(folder, codec_path)
    code = generated_wire_code(f"{PACKAGE}/msg/Gid")
    assert code is not None
    assert code.little.to_dict.__module__ == f"pyconnect_generated.{PACKAGE}.wire_codecs"
