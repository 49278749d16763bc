"""The ``pyconnect`` CLI, run in-process: output, exit codes, one-line errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Image
from std_msgs.msg import String

from pyconnect.cli import format_value, main, main_entry
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
    assert out.splitlines() == [
        f"path:      {bag}",
        "storage:   mcap (1 file)",
        "messages:  7",
        "start:     1970-01-01 00:00:01.000000000 UTC (1.000000000)",
        "end:       1970-01-01 00:00:02.000000001 UTC (2.000000001)",
        "duration:  1.000000001 s",
        "topics:    2",
        "  /camera   sensor_msgs/msg/Image  2 msgs  cdr",
        "  /chatter  std_msgs/msg/String    5 msgs  cdr",
    ]


def test_echo_topic_and_limit(bag: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bag", "echo", str(bag), "--topic", "/chatter", "--limit", "2"]) == 0
    assert capsys.readouterr().out.splitlines() == [
        "/chatter 1.000000000 'hi 0'",
        "/chatter 1.000000001 'hi 1'",
    ]
    assert main(["bag", "echo", str(bag), "--topic", "/chatter", "--limit", "1", "--dict"]) == 0
    assert capsys.readouterr().out.splitlines() == ["/chatter 1.000000000 {'data': 'hi 0'}"]


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


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["bag", "info", "/no/such/bag"], "/no/such/bag: no such bag file or directory"),
        (
            ["bag", "ech"],
            "argument action: invalid choice: 'ech' (choose from 'info', 'echo', 'export')",
        ),
        (["bag", "export", "x"], "the following arguments are required: --topic, --to"),
        (["bag", "echo", "x", "--limit", "many"], "argument --limit: invalid int value: 'many'"),
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
    assert capsys.readouterr().err == "pyconnect: error: --limit: expected a count >= 0, got -1\n"


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
    assert out == "/chatter 0.000000002 'ok'\n"
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
