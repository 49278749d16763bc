"""A fake install prefix holding ``idlpkg``, whose ``Reading`` has only an .idl file (as a package
built from .idl files has) and whose ``Sample`` (.msg and .idl, as rosidl installs) nests it."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from pyconnect.typesys.installed_definition_text import installed_definition
from pyconnect.typesys.packages import installed_share_dirs

READING_IDL = """module idlpkg {
  module msg {
    struct Reading {
      double value;
      string<10> label;
    };
  };
};
"""
SAMPLE_MSG = "# A sample\nReading reading  # nested from idl\nint32[<=5] vals\n"
SAMPLE_IDL = """// generated from rosidl_adapter/resource/msg.idl.em

#include "idlpkg/msg/Reading.idl"

module idlpkg {
  module msg {
    struct Sample {
      idlpkg::msg::Reading reading;
      sequence<int32, 5> vals;
    };
  };
};
"""


def install_idl_package(root: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Lay the prefix out under ``root``, put it first on AMENT_PREFIX_PATH; its share dir."""
    index = root / "share" / "ament_index" / "resource_index" / "rosidl_interfaces"
    index.mkdir(parents=True)
    (index / "idlpkg").write_text("msg/Reading.idl\nmsg/Sample.idl\nmsg/Sample.msg\n")
    share = root / "share" / "idlpkg"
    (share / "msg").mkdir(parents=True)
    (share / "msg" / "Reading.idl").write_text(READING_IDL)
    (share / "msg" / "Sample.idl").write_text(SAMPLE_IDL)
    (share / "msg" / "Sample.msg").write_text(SAMPLE_MSG)
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(root))
    _forget_installed()
    return share


def _forget_installed() -> None:
    installed_share_dirs.cache_clear()
    installed_definition.cache_clear()


@pytest.fixture
def idl_share(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    share = install_idl_package(tmp_path / "prefix", monkeypatch)
    yield share
    monkeypatch.undo()
    _forget_installed()
