"""Generated dict codecs made from another version of a *nested* type are not used either.

The top-level fields of such a type are unchanged, so only its RIHS01 hash (which covers every
nested type) tells: a stale folder on the codec search path must not drop a field added below.
"""

from __future__ import annotations

import shutil
import sys
from collections.abc import Iterator
from pathlib import Path

import pyconnect_generated
import pytest
from rmw_dds_common.msg import Gid, NodeEntitiesInfo, ParticipantEntitiesInfo

from pyconnect.codecs import Registry, search_path
from pyconnect.codecs.type_code import generated_dict_functions
from pyconnect.codegen.cli import main
from pyconnect.typesys.packages import installed_packages

PACKAGE = "rmw_dds_common"  # installed with the wheels, not one of generated/'s packages
OUTER = f"{PACKAGE}/msg/ParticipantEntitiesInfo"  # holds NodeEntitiesInfo[], which changes


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


def _message() -> ParticipantEntitiesInfo:
    node = NodeEntitiesInfo(node_namespace="/", node_name="n",
                            reader_gid_seq=[Gid(data=[1] * 16)],
                            writer_gid_seq=[Gid(data=[2] * 16)])  # fmt: skip
    return ParticipantEntitiesInfo(gid=Gid(data=[3] * 16), node_entities_info_seq=[node])


def test_stale_nested_dict_code_falls_back_to_the_installed_class(
    tmp_path: Path, codec_path: Path
) -> None:
    # NodeEntitiesInfo as it was before writer_gid_seq was added, generated into the out folder.
    folder = tmp_path / PACKAGE
    shutil.copytree(installed_packages()[PACKAGE].share / "msg", folder / "msg")
    (folder / "msg" / "NodeEntitiesInfo.msg").write_text(
        "string<=256 node_namespace\nstring<=256 node_name\nGid[] reader_gid_seq\n"
    )
    _build_from(folder, codec_path)
    assert generated_dict_functions(OUTER) is None
    registry = Registry()
    msg = _message()
    d = registry.to_dict(msg)
    assert d["node_entities_info_seq"][0]["writer_gid_seq"] == [{"data": bytes([2] * 16)}]
    assert registry.from_dict(d, ParticipantEntitiesInfo) == msg


def test_current_generated_dict_code_is_used(tmp_path: Path, codec_path: Path) -> None:
    folder = tmp_path / PACKAGE
    shutil.copytree(installed_packages()[PACKAGE].share / "msg", folder / "msg")
    _build_from(folder, codec_path)
    functions = generated_dict_functions(OUTER)
    assert functions is not None
    assert functions.to_dict.__module__ == f"pyconnect_generated.{PACKAGE}.dict_codecs"
    assert functions.from_dict(functions.to_dict(_message())) == _message()
