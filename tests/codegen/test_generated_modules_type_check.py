"""The generated modules themselves pass mypy --strict when a user's mypy follows into them."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.codegen.test_typed_dicts import GENERATED, ROOT, mypy_errors

# std_msgs/dict_codecs has an empty message (Empty), float32 fields and a linked package
# (builtin_interfaces); importing it runs through pyconnect_generated/__init__.py.
USE = """
from std_msgs.msg import Empty
from pyconnect_generated.std_msgs.dict_codecs import empty_to_dict

print(empty_to_dict(Empty()))
"""


def test_generated_modules_pass_strict_mypy_followed_normally(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # An editable install hides generated/ behind an import hook that mypy cannot follow.
    monkeypatch.setenv("MYPYPATH", f"{GENERATED}:{ROOT / 'src'}")
    errors, status = mypy_errors(tmp_path, USE, follow_imports="normal")
    assert errors == []
    assert status == 0
