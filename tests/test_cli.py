"""The ``pyconnect`` CLI, run in-process: output, exit codes, one-line errors."""

from __future__ import annotations

import argparse
import base64
import json
import os
import stat
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Image
from std_msgs.msg import String

from pyconnect.cli import build_parser, format_value, main, main_entry
from pyconnect.record.mcap_recorder import McapRecorder


@pytest.fixture
def bag(tmp_path: Path) -> Path:
    with McapRecorder(tmp_path / "bag") as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        recorder.add_topic("/camera", "sensor_msgs/msg/Image")
        for i in range(5):
            recorder.write(
                "/chatter",
                bytes(serialize_message(String(data=f"hi {i}"))),
                log_time_ns=1_000_000_000 + i,
            )
        for i in range(2):
            image = Image(height=2, width=3, encoding="mono8", step=3)
            image.data.frombytes(bytes(range(i, i + 6)))
            recorder.write(
                "/camera", bytes(serialize_message(image)), log_time_ns=2_000_000_000 + i
            )
    return tmp_path / "bag"


def test_info(bag: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bag", "info", str(bag)]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    size = (bag / "bag_0.mcap").stat().st_size
    assert out.splitlines() == [
        f"path:      {bag}",
        "storage:   mcap (1 file)",
        f"  bag_0.mcap  {size / 1024:.1f} KiB",
        f"size:      {size / 1024:.1f} KiB",
        "messages:  7",
        "start:     1970-01-01 00:00:01.000000000 UTC (1.000000000)",
        "end:       1970-01-01 00:00:02.000000001 UTC (2.000000001)",
        "duration:  1.000000001 s",
        "topics:    2",
        "  /camera   sensor_msgs/msg/Image  2 msgs  cdr",
        "  /chatter  std_msgs/msg/String    5 msgs  cdr",
        "services:  0",
    ]


def test_info_lists_services_apart(capsys: pytest.CaptureFixture[str]) -> None:
    from tests.conftest import require_sample_bags
    from tests.record.bag_samples import BAGS

    bag = (
        BAGS / "ros2_rosbag2_jazzy/rosbag2_tests/resources/mcap/bag_with_topics_and_service_events"
    )
    require_sample_bags(bag, bag.exists())
    assert main(["bag", "info", str(bag)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[lines.index("services:  2") + 1 :] == [
        "  /test_service1/_service_event  test_msgs/srv/BasicTypes_Event  4 events  cdr",
        "  /test_service2/_service_event  test_msgs/srv/BasicTypes_Event  4 events  cdr",
    ]


def test_echo_yaml_topic_and_limit(bag: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bag", "echo", str(bag), "--topic", "/chatter", "--limit", "2"]) == 0
    assert capsys.readouterr().out.splitlines() == [
        "# /chatter 1.000000000 std_msgs/msg/String",
        "hi 0",
        "---",
        "# /chatter 1.000000001 std_msgs/msg/String",
        "hi 1",
        "---",
    ]
    assert main(["bag", "echo", str(bag), "--topic", "/chatter", "--limit", "1", "--dict"]) == 0
    assert capsys.readouterr().out.splitlines() == [
        "# /chatter 1.000000000 std_msgs/msg/String",
        "data: hi 0",
        "---",
    ]


def test_echo_json_lines(bag: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bag", "echo", str(bag), "--json", "--limit", "1"]) == 0
    assert [json.loads(line) for line in capsys.readouterr().out.splitlines()] == [
        {"topic": "/chatter", "log_time_ns": 1_000_000_000, "msg_type": "std_msgs/msg/String",
         "value": "hi 0"}
    ]  # fmt: skip
    assert main(["bag", "echo", str(bag), "--json", "--topic", "/camera", "--dict"]) == 0
    first = json.loads(capsys.readouterr().out.splitlines()[0])
    assert first["value"]["data"] == base64.b64encode(bytes(range(6))).decode()
    assert (first["value"]["height"], first["value"]["width"]) == (2, 3)


def test_echo_field_and_time_window(bag: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["bag", "echo", str(bag), "--json", "--field", "height", "--topic", "/camera"]
    assert main(argv) == 0
    assert [json.loads(line)["value"] for line in capsys.readouterr().out.splitlines()] == [2, 2]
    # --start/--end in seconds: absolute, or an offset from the bag's start when smaller
    argv = ["bag", "echo", str(bag), "--json", "--field", "data", "--topic", "/chatter"]
    assert main([*argv, "--start", "1.000000002", "--end", "1.000000003"]) == 0
    values = [json.loads(line)["value"] for line in capsys.readouterr().out.splitlines()]
    assert values == ["hi 2", "hi 3"]
    assert main([*argv, "--start", "0.000000004"]) == 0
    values = [json.loads(line)["value"] for line in capsys.readouterr().out.splitlines()]
    assert values == ["hi 4"]
    assert main([*argv[:-2], "--field", "nope"]) == 2
    assert capsys.readouterr().err == (
        "pyconnect: error: --field nope: /chatter: no field 'nope' in the message (fields: data)\n"
    )


def test_echo_summarises_arrays() -> None:
    assert format_value(np.zeros((480, 640, 3), np.uint8)) == (
        "ndarray(shape=(480, 640, 3), dtype=uint8)"
    )
    assert format_value({"a": np.arange(3), "b": b"x" * 40, "c": list(range(20))}) == (
        "{'a': array([0, 1, 2], dtype=int64), 'b': <40 bytes>, "
        "'c': [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, ... 4 more]}"
    )


def test_export(bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        main(["bag", "export", str(bag), "--topic", "/chatter", "--to", str(tmp_path / "out")]) == 0
    )
    assert capsys.readouterr().out == f"/chatter: 5 message(s) to {tmp_path / 'out'}: 5 jsonl\n"
    lines = (tmp_path / "out" / "messages.jsonl").read_text().splitlines()
    assert [json.loads(line) for line in lines] == [
        {"log_time_ns": 1_000_000_000 + i, "value": f"hi {i}"} for i in range(5)
    ]
    assert (
        main(["bag", "export", str(bag), "--topic", "/camera", "--to", str(tmp_path / "img")]) == 0
    )
    names = sorted(p.name for p in (tmp_path / "img").iterdir())
    assert names == ["000000_2000000000.png", "000001_2000000001.png"]


def test_export_honours_the_umask(bag: Path, tmp_path: Path) -> None:
    old = os.umask(0o027)
    try:
        argv = ["bag", "export", str(bag), "--topic", "/chatter", "--topic", "/camera"]
        assert main([*argv, "--to", str(tmp_path / "out")]) == 0
    finally:
        os.umask(old)
    modes = {p.name: stat.S_IMODE(p.stat().st_mode) for p in (tmp_path / "out").rglob("*.*")}
    assert modes == {
        "messages.jsonl": 0o640,
        "000000_2000000000.png": 0o640,
        "000001_2000000001.png": 0o640,
    }


def test_export_several_topics_and_refuse_to_overwrite(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    argv = [
        "bag",
        "export",
        str(bag),
        "--topic",
        "/chatter",
        "--topic",
        "/camera",
        "--to",
        str(out),
    ]
    assert main(argv) == 0
    assert capsys.readouterr().out.splitlines() == [
        f"/chatter: 5 message(s) to {out / 'chatter'}: 5 jsonl",
        f"/camera: 2 message(s) to {out / 'camera'}: 2 png",
    ]
    assert main(argv) == 2
    assert capsys.readouterr().err == (
        f"pyconnect: error: {out / 'chatter'}: already holds an export (messages.jsonl); "
        "use force=True (--force) to overwrite it\n"
    )
    (out / "camera" / "000007_1.png").write_bytes(b"stale")
    assert main([*argv, "--force"]) == 0
    assert sorted(p.name for p in (out / "camera").iterdir()) == [
        "000000_2000000000.png",
        "000001_2000000001.png",
    ]


def test_damaged_bag_exits_1_unless_told_to_go_on(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cut = tmp_path / "cut.mcap"
    data = (bag / "bag_0.mcap").read_bytes()
    cut.write_bytes(data[: len(data) - 100])  # inside the summary: the messages are intact
    for action in (
        ["info"],
        ["echo"],
        ["export", "--topic", "/chatter", "--to", str(tmp_path / "x")],
        ["export", "--format", "parquet", "--to", str(tmp_path / "tables")],
    ):
        assert main(["bag", action[0], str(cut), *action[1:]]) == 1, action
        err = capsys.readouterr().err
        assert err.startswith(
            f"pyconnect: {cut}: damaged bag: {cut} at byte {len(data) - 100}: the file is cut short"
        )
        argv = ["bag", action[0], str(cut), *action[1:], "--ignore-damage"]
        if action[0] == "export":
            argv.append("--force")
        assert main(argv) == 0, action
        assert "damaged bag" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["bag", "info", "/no/such/bag"], "/no/such/bag: no such bag file or directory"),
        (
            ["bag", "ech"],
            "argument action: invalid choice: 'ech' (choose from 'info', 'echo', 'export', 'record', 'play')",
        ),
        (["bag", "export", "x"], "the following arguments are required: --to"),
        (
            ["bag", "echo", "x", "--limit", "many"],
            "argument --limit: expected a whole number >= 0, got 'many'",
        ),
        ([], "the following arguments are required: command"),
    ],
)
def test_errors_are_one_line_with_status_2(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert (out, err) == ("", f"pyconnect: error: {message}\n")


def test_unknown_topic_and_negative_limit(bag: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bag", "echo", str(bag), "--topic", "/nope"]) == 2
    assert capsys.readouterr().err == (
        f"pyconnect: error: {bag}: no topic /nope in this bag (topics: /camera, /chatter)\n"
    )
    assert main(["bag", "echo", str(bag), "--limit", "-1"]) == 2
    assert capsys.readouterr().err == (
        "pyconnect: error: argument --limit: expected a whole number >= 0, got '-1'\n"
    )


def test_help_exits_zero(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bag", "--help"]) == 0
    assert "info" in capsys.readouterr().out


def test_undecodable_messages_give_status_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with McapRecorder(tmp_path / "bag") as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        recorder.write("/chatter", b"\x00\x01\x00\x00\xff\xff\xff\x7f", log_time_ns=1)
        recorder.write("/chatter", bytes(serialize_message(String(data="ok"))), log_time_ns=2)
    assert main(["bag", "echo", str(tmp_path / "bag")]) == 1
    out, err = capsys.readouterr()
    assert out == "# /chatter 0.000000002 std_msgs/msg/String\nok\n---\n"
    assert err.startswith("pyconnect: 1 message(s) not decoded; first: /chatter[0]: ")
    assert err.count("\n") == 1


def test_main_entry_exits_with_the_status(
    bag: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr("sys.argv", ["pyconnect", "bag", "info", str(bag / "nope")])
    with pytest.raises(SystemExit) as caught:
        main_entry()
    assert caught.value.code == 2
    assert (
        capsys.readouterr().err
        == f"pyconnect: error: {bag / 'nope'}: no such bag file or directory\n"
    )


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    from pyconnect import __version__

    assert main(["--version"]) == 0
    assert capsys.readouterr().out == f"pyconnect {__version__}\n"


def test_codecgen_version_and_a_folder_one_too_deep(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from pyconnect import __version__
    from pyconnect.codegen.cli import main as codecgen

    with pytest.raises(SystemExit) as exited:
        codecgen(["--version"])
    assert exited.value.code == 0
    assert capsys.readouterr().out == f"codecgen {__version__}\n"
    folder = tmp_path / "tutorial_interfaces" / "msg"
    folder.mkdir(parents=True)
    (folder / "Num.msg").write_text("int64 num\n")
    assert codecgen(["build", "--from", str(folder), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr() == (
        "",
        f"codecgen: --from {folder}: give the package folder, the one holding msg/, srv/ or "
        f"action/ (here {folder.parent})\n",
    )
    assert not (tmp_path / "out").exists()


def _subcommands(
    parser: argparse.ArgumentParser, path: tuple[str, ...] = ()
) -> Iterator[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield (*path, name), sub
                yield from _subcommands(sub, (*path, name))


def test_every_subcommand_help_ends_with_its_examples_one_per_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("COLUMNS", "80")  # argparse wraps text to this width
    walked = dict(_subcommands(build_parser()))
    assert ("topic", "echo") in walked
    assert ("bag", "record") in walked
    for path, parser in walked.items():
        _text, found, examples = parser.format_help().rpartition("\nexamples:\n")
        assert found, f"pyconnect {' '.join(path)} --help has no examples"
        lines = examples.rstrip("\n").split("\n")
        for line in lines:
            assert line.startswith("  pyconnect "), (path, line)
            assert line.count("pyconnect") == 1, (path, line)  # not run into one paragraph
        command = f"  pyconnect {' '.join(path)}"
        assert any(line == command or line.startswith(command + " ") for line in lines), path


@pytest.mark.parametrize(
    "argv",
    [["pyconnect.cli", "interface", "list", "--packages"], ["pyconnect.codegen", "list"]],
)
def test_a_closed_stdout_ends_the_command_quietly(argv: list[str]) -> None:
    # `... | head -1`: the reader has gone before the output is written (the read end is closed
    # first, so no timing); without PYTHONUNBUFFERED the last of it is written at exit.
    read_end, write_end = os.pipe()
    os.close(read_end)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    try:
        done = subprocess.run(
            [sys.executable, "-m", *argv],
            stdout=write_end,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
            check=False,
            timeout=120,
        )
    finally:
        os.close(write_end)
    assert (done.returncode, done.stderr) == (0, "")


def test_bag_echo_json_writes_non_finite_floats_as_strict_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from std_msgs.msg import Float64

    bag = tmp_path / "floats"
    with McapRecorder(bag) as recorder:
        recorder.add_topic("/f", "std_msgs/msg/Float64")
        for stamp, number in enumerate([float("nan"), float("inf"), -float("inf"), 1.5], 1):
            recorder.write("/f", serialize_message(Float64(data=number)), log_time_ns=stamp)
    assert main(["bag", "echo", str(bag), "--json"]) == 0

    def refuse(constant: str) -> None:
        raise ValueError(f"not JSON: {constant}")

    lines = capsys.readouterr().out.splitlines()
    values = [json.loads(line, parse_constant=refuse)["value"] for line in lines]
    assert values == ["nan", "inf", "-inf", 1.5]  # as topic echo --json writes them


# Runs ``pyconnect`` as an install without the `ros` extra sees it: every import of rclpy fails.
WITHOUT_RCLPY = """
import sys
sys.modules["rclpy"] = None
from pyconnect.cli import main
status = main(sys.argv[1:])
print("rclpy imported:", sys.modules["rclpy"] is not None, file=sys.stderr)
sys.exit(status)
"""


def _run_without_rclpy(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", WITHOUT_RCLPY, *argv],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )


def test_the_offline_commands_run_without_rclpy() -> None:
    from pyconnect import __version__
    from tests.conftest import require_sample_bags
    from tests.record.bag_samples import BAGS

    shared_bag = BAGS / "evo" / "nav2_turtlebot.mcap"
    require_sample_bags(BAGS, shared_bag.exists())
    help_run = _run_without_rclpy("--help")
    assert (help_run.returncode, help_run.stderr) == (0, "rclpy imported: False\n")
    assert "topic" in help_run.stdout
    version_run = _run_without_rclpy("--version")
    assert (version_run.returncode, version_run.stdout) == (0, f"pyconnect {__version__}\n")
    info_run = _run_without_rclpy("bag", "info", str(shared_bag))
    assert (info_run.returncode, info_run.stderr) == (0, "rclpy imported: False\n")
    assert "/odom" in info_run.stdout


@pytest.mark.parametrize(
    ("argv", "reason"),
    [
        (["topic", "list"], "import of rclpy halted; None in sys.modules"),
        # a name is expanded by rcl while the command line is read
        (
            ["topic", "echo", "chatter"],
            "No module named 'rclpy.exceptions'; 'rclpy' is not a package",
        ),
        (["bag", "play", "missing_bag"], "import of rclpy halted; None in sys.modules"),
    ],
)
def test_a_live_command_without_rclpy_names_the_ros_extra(argv: list[str], reason: str) -> None:
    done = _run_without_rclpy(*argv)
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr.splitlines() == [
        f"pyconnect: error: this command talks to a live ROS 2 graph and needs rclpy ({reason}): "
        "pip install 'pyconnect-ros[ros]', or source a ROS 2 Jazzy install",
        "rclpy imported: False",
    ]
