"""Generated codecs that exist but cannot be imported are a CodecNotFoundError, not an ImportError.

A type's generated dict codec imports the rclpy classes of its package and of every package it
uses: a dependency not installed (or uninstalled), or a folder of sources shadowing it as a
namespace package, must say which type and module failed, with the import's own error.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pyconnect_generated
import pytest

from pyconnect import codecs
from pyconnect.codecs import Registry, search_path
from pyconnect.codecs.type_code import generated_dict_functions
from pyconnect.errors import CodecNotFoundError

STATUS = "pcx_robot_msgs/msg/Status"
LIMITS = "pcx_base_msgs/msg/Limits"


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")


def _generated(out: Path, package: str, full_name: str, imports: str) -> None:
    """A stand-in for what ``codecgen build --from`` writes: an index and a dict codec."""
    root = out / "pyconnect_generated" / package
    _write(root / "__init__.py", "")
    _write(
        root / "index.py",
        f"TYPE_NAMES = frozenset({{{full_name!r}}})\nTYPE_HASHES: dict[str, str] = {{}}\n",
    )
    _write(root / "dict_codecs.py", f"{imports}\nDICT_CODECS: dict[str, object] = {{}}\n")


@pytest.fixture
def out(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A codec folder on the search path; the search path and modules restored after."""
    saved = list(pyconnect_generated.__path__)
    folder = tmp_path / "out"
    folder.mkdir()
    monkeypatch.setenv(search_path.ENV_VAR, str(folder))
    yield folder
    pyconnect_generated.__path__[:] = saved
    for name in [m for m in sys.modules if m.split(".")[0].startswith("pcx_") or ".pcx_" in m]:
        del sys.modules[name]


def test_a_dependency_that_is_not_installed_is_codec_not_found(out: Path) -> None:
    # robot's codec imports base's (as codecgen links them), which imports base's classes.
    _generated(out, "pcx_base_msgs", LIMITS, "from pcx_base_msgs.msg import Limits")
    _generated(
        out, "pcx_robot_msgs", STATUS, "from pyconnect_generated.pcx_base_msgs import dict_codecs"
    )
    search_path.refresh()
    with pytest.raises(CodecNotFoundError) as caught:
        generated_dict_functions(STATUS)
    message = str(caught.value)
    assert message.startswith(f"{STATUS}: ")
    assert "pyconnect_generated.pcx_robot_msgs.dict_codecs" in message
    assert "No module named 'pcx_base_msgs'" in message
    with pytest.raises(CodecNotFoundError, match="No module named 'pcx_base_msgs'"):
        codecs.lookup(STATUS)
    with pytest.raises(CodecNotFoundError, match="No module named 'pcx_base_msgs'"):
        Registry().lookup_dict(STATUS)


def test_sources_shadowing_the_package_are_codec_not_found(
    out: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Run from the folder that holds the package's sources: pcx_base_msgs/msg/ has no
    # __init__.py, so it imports as a namespace package without the class.
    (tmp_path / "src" / "pcx_base_msgs" / "msg").mkdir(parents=True)
    monkeypatch.syspath_prepend(str(tmp_path / "src"))
    _generated(out, "pcx_base_msgs", LIMITS, "from pcx_base_msgs.msg import Limits")
    search_path.refresh()
    with pytest.raises(CodecNotFoundError) as caught:
        Registry().lookup_dict(LIMITS)
    message = str(caught.value)
    assert "pyconnect_generated.pcx_base_msgs.dict_codecs" in message
    assert "cannot import name 'Limits'" in message


def test_a_type_whose_own_package_is_missing_still_falls_back(out: Path) -> None:
    _generated(out, "pcx_base_msgs", LIMITS, "from pcx_base_msgs.msg import Limits")
    search_path.refresh()
    assert generated_dict_functions(LIMITS) is None
    with pytest.raises(CodecNotFoundError, match="cannot be imported"):
        Registry().lookup_dict(LIMITS)


def test_a_broken_generated_module_stays_visible(out: Path) -> None:
    # Not an import problem: a bug in the generated code must not read as "no codec".
    _generated(out, "pcx_base_msgs", LIMITS, "raise RuntimeError('bug in generated code')")
    search_path.refresh()
    with pytest.raises(RuntimeError, match="bug in generated code"):
        generated_dict_functions(LIMITS)


def test_a_class_whose_dependency_was_uninstalled_is_codec_not_found(
    out: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A compiled package whose dependency was uninstalled since: its codecs are gone with the
    # dependency's, and its class imports the dependency when an instance is made.
    package = tmp_path / "src" / "pcx_robot_msgs" / "msg"
    _write(package.parent / "__init__.py", "")
    _write(
        package / "__init__.py",
        "class Status:\n"
        "    SLOT_TYPES = ()\n\n"
        "    @classmethod\n"
        "    def get_fields_and_field_types(cls):\n"
        "        return {}\n\n"
        "    def __init__(self):\n"
        "        from pcx_base_msgs.msg import Limits  # noqa: F401\n",
    )
    monkeypatch.syspath_prepend(str(tmp_path / "src"))
    _generated(
        out, "pcx_robot_msgs", STATUS, "from pyconnect_generated.pcx_base_msgs import dict_codecs"
    )
    search_path.refresh()
    with pytest.raises(CodecNotFoundError) as caught:
        Registry().lookup_dict(STATUS)
    assert str(caught.value) == (
        f"{STATUS}: no generated codec and its class cannot be used: "
        "No module named 'pcx_base_msgs'"
    )
