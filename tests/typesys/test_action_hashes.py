"""Action hashes, implicit services included, equal those rosidl's build installs.

rosidl_generator_type_description writes ``share/<pkg>/action/<Name>.json`` at build time with
the RIHS01 hash of the action and of every type it implies (``_SendGoal``, ``_GetResult``,
``_FeedbackMessage``, their requests, responses and events); rmw_zenoh puts the services'
hashes in an action's key expressions. The type model and the generated index must agree.
"""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import pytest

from pyconnect.typesys.loading import load_packages
from pyconnect.typesys.packages import installed_packages


def _installed_hashes(share: Path) -> dict[str, dict[str, str]]:
    """Action name -> {type name: hash} from the installed type description files."""
    found: dict[str, dict[str, str]] = {}
    for path in sorted((share / "action").glob("*.json")):
        description = json.loads(path.read_text(encoding="utf-8"))
        found[path.stem] = {h["type_name"]: h["hash_string"] for h in description["type_hashes"]}
    return found


@pytest.mark.parametrize("package", ["test_msgs"])
def test_every_action_hash_equals_the_installed_type_description(package: str) -> None:
    installed = _installed_hashes(installed_packages()[package].share)
    assert set(installed) == {"Fibonacci", "NestedMessage"}
    packages, _types = load_packages([package])
    index = importlib.import_module(f"pyconnect_generated.{package}.index")
    for action in packages[package].actions:
        expected = installed[action.name]
        full = action.full_name
        assert action.type_hash == expected[full]
        assert action.send_goal_hash == expected[f"{full}_SendGoal"]
        assert action.get_result_hash == expected[f"{full}_GetResult"]
        for msg in action.messages:
            assert msg.type_hash == expected[msg.full_name], msg.full_name
        own = {name: value for name, value in expected.items() if name.startswith(full)}
        listed = {name: value for name, value in index.TYPE_HASHES.items() if name.startswith(full)}
        assert listed == own
