"""The generated TypedDicts make ``*_to_dict`` results type-check under mypy."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest
from mypy import api

ROOT = Path(__file__).resolve().parents[2]
GENERATED = ROOT / "generated"
USE = """
from sensor_msgs.msg import JointState
from pyconnect_generated.sensor_msgs.dict_codecs import joint_state_to_dict

d = joint_state_to_dict(JointState())
positions: list[float] = d["position"]
stamp: int = d["header"]["stamp"]["sec"]
wrong: str = d["position"]
missing = d["positon"]
"""


def mypy_errors(
    tmp_path: Path, source: str, *, follow_imports: str = "silent"
) -> tuple[list[str], int]:
    """mypy --strict on ``source`` as a user's script: its error texts and exit status.

    ``follow_imports="normal"`` reports errors inside the modules it imports too, as
    "path:line: message" (mypy's default, what a user's plain ``mypy --strict`` does).
    """
    script = tmp_path / "use.py"
    script.write_text(source)
    out, _, status = api.run([
        "--strict", "--no-incremental", "--ignore-missing-imports",
        f"--follow-imports={follow_imports}",
        "--cache-dir", str(tmp_path / "cache"), "--config-file", "", str(script),
    ])  # fmt: skip
    keep_path = follow_imports != "silent"
    errors = [
        line.replace(": error: ", ": ", 1) if keep_path else line.split(": error: ", 1)[1]
        for line in out.splitlines()
        if ": error: " in line
    ]
    return errors, status


def test_to_dict_results_are_typed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # An editable install hides generated/ behind an import hook that mypy cannot follow.
    monkeypatch.setenv("MYPYPATH", str(GENERATED))
    errors, status = mypy_errors(tmp_path, USE)
    assert status == 1
    assert errors == [
        'Incompatible types in assignment (expression has type "list[float]", variable has type "str")  [assignment]',
        'TypedDict "JointStateDict" has no key "positon"  [typeddict-item]',
    ]


def test_docstring_example_type_checks(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # The module docstring shows how to get a TypedDict from codecs.to_dict (which returns
    # dict[str, Any]): its example must pass mypy --strict, and the bare assignment must not.
    module = importlib.import_module("pyconnect_generated.sensor_msgs.typed_dicts")
    examples = [
        line.strip() for line in (module.__doc__ or "").splitlines() if line.startswith("    ")
    ]
    assert examples == ["d = cast(BatteryStateDict, codecs.to_dict(msg))"]
    monkeypatch.setenv("MYPYPATH", f"{GENERATED}:{ROOT / 'src'}")
    source = (
        "from typing import cast\n"
        "from pyconnect import codecs\n"
        "from pyconnect_generated.sensor_msgs.typed_dicts import BatteryStateDict\n"
        "msg = object()\n"
        f"{examples[0]}\n"
        "voltage: float = d['voltage']\n"
        "bare: BatteryStateDict = codecs.to_dict(msg)\n"
    )
    errors, status = mypy_errors(tmp_path, source)
    assert status == 1
    assert errors == [
        'Incompatible types in assignment (expression has type "dict[str, Any]", variable has type "BatteryStateDict")  [assignment]',
    ]
