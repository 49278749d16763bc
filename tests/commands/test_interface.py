"""``pyconnect interface show`` of types defined in .idl files."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.commands.common import UsageError
from pyconnect.commands.interface import interface_text
from tests.typesys.idl_prefix import READING_IDL, SAMPLE_MSG, idl_share

__all__ = ["idl_share"]  # a fixture


def test_a_type_with_only_an_idl_file_shows_that_file(idl_share: Path) -> None:
    assert interface_text("idlpkg/msg/Reading") == READING_IDL
    assert interface_text("idlpkg/Reading") == READING_IDL
    assert interface_text("idlpkg/msg/Reading", expand=False) == READING_IDL


def test_a_nested_idl_type_is_not_expanded_into_the_msg_text(idl_share: Path) -> None:
    assert interface_text("idlpkg/msg/Sample") == SAMPLE_MSG


def test_a_missing_type_names_both_files(idl_share: Path) -> None:
    with pytest.raises(UsageError) as caught:
        interface_text("idlpkg/msg/Nothing")
    assert str(caught.value) == (
        f"idlpkg/msg/Nothing: no such type (Nothing.msg is not in {idl_share}, nor Nothing.idl)"
    )
