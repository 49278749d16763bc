"""Log directories: layout, the time stamp, and names that must never escape the log root."""

from __future__ import annotations

import re
from datetime import datetime
from pathlib import Path

import pytest

from pyconnect.record.log_dirs import (
    MAX_COMPONENT,
    default_log_root,
    distinct_path_components,
    make_log_dirs,
    safe_path_component,
)

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


def test_a_long_name_is_cut_to_a_length_file_systems_take(tmp_path: Path) -> None:
    # A valid ROS topic name of 240 characters; a file name may have 255 bytes.
    topic = "/" + "/".join(f"seg{i:02d}_x" for i in range(30))
    component = safe_path_component(topic)
    assert len(component) == MAX_COMPONENT
    assert component.startswith("seg00_x__seg01_x__")
    assert re.fullmatch(r".*-[0-9a-f]{10}", component)
    assert safe_path_component(topic) == component  # stable: the same folder every session
    sibling = topic[:-1] + "y"  # same start, another name: another folder
    assert safe_path_component(sibling) != component
    dirs = make_log_dirs(tmp_path, topic, [topic, sibling], now=NOW)
    assert all(d.is_dir() for d in dirs.values())
    assert len(set(dirs.values())) == 2
    assert safe_path_component("a" * MAX_COMPONENT) == "a" * MAX_COMPONENT  # short enough


def test_names_that_clean_alike_get_distinct_components() -> None:
    names = ["/cam_/info", "/cam/_info", "/a/b", "/a__b", "a__b_2", "/Chatter", "/chatter"]
    assert distinct_path_components(names) == {
        "/cam_/info": "cam___info",
        "/cam/_info": "cam___info_2",
        "/a/b": "a__b",
        "/a__b": "a__b_2",
        "a__b_2": "a__b_2_2",
        "/Chatter": "Chatter",
        "/chatter": "chatter_2",  # one folder on macOS and Windows otherwise
    }
    assert distinct_path_components(["/x", "/y"], taken=["x"]) == {"/x": "x_2", "/y": "y"}
