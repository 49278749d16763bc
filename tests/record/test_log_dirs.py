"""Log directories: layout, the time stamp, and names that must never escape the log root."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import pytest

from pyconnect.record.log_dirs import default_log_root, make_log_dirs, safe_path_component

NOW = datetime(2026, 11, 23, 5, 6, 7)


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("camera", "camera"),
        ("/a/b", "a__b"),
        ("../../x", "x"),
        ("..", "_"),
        (".", "_"),
        ("", "_"),
        ("/", "_"),
        (".hidden", "hidden"),
        ("a\\..\\b", "a__b"),
        ("cam era:1", "cam_era_1"),
        ("/robot/camera/image_raw", "robot__camera__image_raw"),
    ],
)
def test_safe_path_component(name: str, expected: str) -> None:
    assert safe_path_component(name) == expected


def test_make_log_dirs_layout(tmp_path: Path) -> None:
    dirs = make_log_dirs(tmp_path, "my_node", ["camera", "cmd_vel"], now=NOW)
    session = tmp_path / "my_node" / "20261123-050607"
    assert dirs == {"camera": session / "camera", "cmd_vel": session / "cmd_vel"}
    assert all(d.is_dir() for d in dirs.values())


def test_hostile_names_stay_under_the_root(tmp_path: Path) -> None:
    root = tmp_path / "logs"
    dirs = make_log_dirs(root, "../../node", ["../../x", "/a/b", "a__b", "/etc/passwd"], now=NOW)
    resolved_root = root.resolve()
    for directory in dirs.values():
        assert directory.resolve().is_relative_to(resolved_root)
    session = root / "node" / "20261123-050607"
    assert dirs == {
        "../../x": session / "x",
        "/a/b": session / "a__b",
        "a__b": session / "a__b_2",
        "/etc/passwd": session / "etc__passwd",
    }
    assert sorted(p.name for p in tmp_path.iterdir()) == ["logs"]


def test_default_root_honours_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PYCONNECT_LOG_DIR", str(tmp_path))
    assert default_log_root() == tmp_path
    monkeypatch.delenv("PYCONNECT_LOG_DIR")
    monkeypatch.chdir(tmp_path)
    assert default_log_root() == tmp_path / "pyconnect_logs"
