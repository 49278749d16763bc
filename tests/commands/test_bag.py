"""``pyconnect bag echo`` (``pyconnect.commands.bag``): time windows and fields, run in-process."""

from __future__ import annotations

import json
from decimal import Decimal
from pathlib import Path

import pytest
from rclpy.serialization import serialize_message
from std_msgs.msg import ByteMultiArray, Float32MultiArray, String, UInt8MultiArray

from pyconnect.cli import main
from pyconnect.commands.bag import seconds_to_ns
from pyconnect.record.mcap_recorder import McapRecorder

STAMP_NS = 1_778_234_358_028_684_000  # /amcl_pose of evo/nav2_turtlebot: 19 digits


@pytest.fixture
def stamped_bag(tmp_path: Path) -> Path:
    bag = tmp_path / "stamped"
    with McapRecorder(bag) as recorder:
        recorder.add_topic("/n", "std_msgs/msg/Int64")
        for offset in (-1_000_000, -1, 0, 1, 1_000_000):
            recorder.write_value("/n", offset, log_time_ns=STAMP_NS + offset)
    return bag


def _echoed(capsys: pytest.CaptureFixture[str]) -> list[tuple[int, object]]:
    return _records(capsys.readouterr().out)


def _records(out: str) -> list[tuple[int, object]]:
    """(log_time_ns, value) of each line ``echo --json`` printed."""
    return [
        (record["log_time_ns"], record["value"]) for record in map(json.loads, out.splitlines())
    ]


def test_echo_window_at_an_exact_absolute_stamp(
    stamped_bag: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A float cannot hold this stamp's nanoseconds: --start/--end equal to it found nothing.
    argv = ["bag", "echo", str(stamped_bag), "--json"]
    assert main([*argv, "--start", "1778234358.028684", "--end", "1778234358.028684"]) == 0
    assert _echoed(capsys) == [(STAMP_NS, 0)]
    assert main([*argv, "--start", "1778234358.028684001", "--end", "1778234358.029684"]) == 0
    assert _echoed(capsys) == [(STAMP_NS + 1, 1), (STAMP_NS + 1_000_000, 1_000_000)]
    assert main([*argv, "--end", "1778234358.028683999"]) == 0
    assert _echoed(capsys) == [(STAMP_NS - 1_000_000, -1_000_000), (STAMP_NS - 1, -1)]


def test_echo_window_offsets_from_the_bags_start_still_work(
    stamped_bag: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = STAMP_NS - 1_000_000
    argv = ["bag", "echo", str(stamped_bag), "--json"]
    assert main([*argv, "--start", "0.000999999", "--end", "0.001000001"]) == 0
    assert _echoed(capsys) == [(first + 999_999, -1), (STAMP_NS, 0), (STAMP_NS + 1, 1)]


def test_echo_window_refuses_what_is_no_number_of_seconds(
    stamped_bag: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bag", "echo", str(stamped_bag), "--start", "soon"]) == 2
    assert capsys.readouterr().err == (
        "pyconnect: error: argument --start: expected seconds, got 'soon'\n"
    )
    assert main(["bag", "echo", str(stamped_bag), "--end", "nan"]) == 2
    assert capsys.readouterr().err == (
        "pyconnect: error: argument --end: expected a finite number of seconds, got 'nan'\n"
    )


def test_seconds_to_ns_is_exact() -> None:
    assert seconds_to_ns(Decimal("1778234358.028684"), 0) == STAMP_NS
    assert seconds_to_ns(1778234358.028684, 0) == STAMP_NS  # a float: as it prints
    assert seconds_to_ns(Decimal("2.5"), STAMP_NS) == STAMP_NS + 2_500_000_000
    assert seconds_to_ns(None, STAMP_NS) is None


@pytest.mark.parametrize(
    ("message", "data"),
    [
        (UInt8MultiArray(data=b"\x07\x08\x09"), [7, 8, 9]),  # uint8[]: bytes in the dict
        (ByteMultiArray(data=[b"\x07", b"\x08", b"\x09"]), [7, 8, 9]),  # byte[]: the same
        (Float32MultiArray(data=[7.0, 8.0, 9.0]), [7.0, 8.0, 9.0]),
    ],
)
def test_echo_field_indexes_into_byte_arrays(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], message: object, data: list[object]
) -> None:
    bag = tmp_path / "arrays"
    with McapRecorder(bag) as recorder:
        recorder.add_topic("/a", f"std_msgs/msg/{type(message).__name__}")
        recorder.write("/a", serialize_message(message), log_time_ns=1)
    assert main(["bag", "echo", str(bag), "--json", "--field", "data.1"]) == 0
    assert _echoed(capsys) == [(1, data[1])]
    assert main(["bag", "echo", str(bag), "--json", "--field", "data.3"]) == 2
    assert capsys.readouterr().err == "pyconnect: error: --field data.3: /a: data: no item 3 of 3\n"


def test_echo_reads_a_bag_with_a_json_topic_and_says_it_left_that_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from mcap.writer import Writer

    bag = tmp_path / "mixed.mcap"
    with bag.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        string = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        chatter = writer.register_channel("/chatter", "cdr", string)
        json_topic = writer.register_channel("/json", "json", 0)
        hi = bytes(serialize_message(String(data="hi")))
        writer.add_message(chatter, log_time=1, data=hi, publish_time=1)
        writer.add_message(json_topic, log_time=2, data=b'{"a": 1}', publish_time=2)
        writer.finish()
    # One JSON topic refused the whole bag (exit 2) though the others decode.
    assert main(["bag", "echo", str(bag), "--json"]) == 0
    captured = capsys.readouterr()
    assert _records(captured.out) == [(1, "hi")]
    assert captured.err == (
        f"pyconnect: {bag}: 1 topic(s) not read, as only 'cdr' topics of a known type can be "
        "decoded: /json (serialised as 'json'); select one with raw=True to read it undecoded\n"
    )
    assert main(["bag", "echo", str(bag), "--topic", "/json"]) == 2
    capsys.readouterr()
    # bag export --format parquet says the same, and writes the decodable topics
    target = tmp_path / "tables"
    assert main(["bag", "export", str(bag), "--format", "parquet", "--to", str(target)]) == 0
    captured = capsys.readouterr()
    assert captured.out == f"/chatter: 1 row(s) to {target / 'chatter.parquet'}\n"
    assert captured.err.startswith(f"pyconnect: {bag}: 1 topic(s) not read")


def test_a_split_bag_missing_a_listed_file_is_read_and_reported_as_damage(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The missing file made info and echo exit 2 without reading the files that were there.
    from pyconnect.record.split_recorder import SplitRecorder

    bag = tmp_path / "split"
    with SplitRecorder(bag, max_ns=1) as recorder:
        recorder.add_topic("/x", "std_msgs/msg/Int64")
        for i in range(3):
            recorder.write("/x", b"\x00\x01\x00\x00" + i.to_bytes(8, "little"), log_time_ns=i)
    (bag / "split_1.mcap").unlink()
    damage = (
        f"{bag / 'metadata.yaml'}: lists split_1.mcap, which is not in the bag; "
        "its messages are not read"
    )
    assert main(["bag", "echo", str(bag), "--json"]) == 1
    captured = capsys.readouterr()
    assert _records(captured.out) == [(0, 0), (2, 2)]
    assert captured.err == (
        f"pyconnect: {bag}: damaged bag: {damage}; "
        "2 message(s) read, the bag's metadata promised 3\n"
    )
    assert main(["bag", "info", str(bag)]) == 1
    captured = capsys.readouterr()
    assert "messages:  2\n" in captured.out
    assert captured.err == f"pyconnect: {bag}: damaged bag: {damage}\n"
    assert main(["bag", "info", str(bag), "--ignore-damage"]) == 0
    assert main(["bag", "echo", str(bag), "--json", "--ignore-damage"]) == 0


def test_info_lists_a_topic_of_two_types_once_per_type(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # As ros2 bag info lists each topic and type: not one type with both counts summed.
    from tests.record.test_bag_info import write_mixed

    bag = write_mixed(tmp_path / "mixed.mcap")
    assert main(["bag", "info", str(bag)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "messages:  8" in lines
    assert lines[lines.index("topics:    3") + 1 :] == [
        "  /mixed  std_msgs/msg/String   4 msgs  cdr",
        "  /mixed  std_msgs/msg/Float64  3 msgs  cdr",
        "  /other  std_msgs/msg/Float64  1 msgs  cdr",
        "services:  0",
    ]


def test_echo_field_of_an_image_is_its_summary_as_topic_echo_shows_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It printed the image's fields, its pixels as a list of 128 items (142 lines a frame)."""
    from sensor_msgs.msg import Image
    from stereo_msgs.msg import DisparityImage

    image = Image(height=2, width=3, encoding="32FC1", step=12, data=bytes(24))
    bag = tmp_path / "disparity"
    with McapRecorder(bag) as recorder:
        recorder.add_topic("/d", "stereo_msgs/msg/DisparityImage")
        recorder.write("/d", serialize_message(DisparityImage(image=image, f=2.0)), log_time_ns=1)
    summary = {"shape": [2, 3], "dtype": "float32", "encoding": "32FC1", "mean": 0.0}
    assert main(["bag", "echo", str(bag), "--json", "--field", "image"]) == 0
    assert _echoed(capsys) == [(1, summary)]
    assert main(["bag", "echo", str(bag), "--field", "image"]) == 0
    assert capsys.readouterr().out.splitlines()[1:] == [
        "Image(shape=(2, 3), dtype=float32, encoding=32FC1, mean=0.000)",
        "---",
    ]
    # Other fields as before: a message field is its dict, a number the number.
    assert main(["bag", "echo", str(bag), "--json", "--field", "f"]) == 0
    assert _echoed(capsys) == [(1, 2.0)]
    assert main(["bag", "echo", str(bag), "--json", "--field", "image.header.stamp"]) == 0
    assert _echoed(capsys) == [(1, {"sec": 0, "nanosec": 0})]


def test_echo_field_of_an_image_that_does_not_decode_is_its_fields_with_a_warning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from sensor_msgs.msg import Image
    from stereo_msgs.msg import DisparityImage

    short = Image(height=2, width=3, encoding="32FC1", step=12, data=bytes(5))
    bag = tmp_path / "short"
    with McapRecorder(bag) as recorder:
        recorder.add_topic("/d", "stereo_msgs/msg/DisparityImage")
        recorder.write("/d", serialize_message(DisparityImage(image=short)), log_time_ns=1)
    assert main(["bag", "echo", str(bag), "--json", "--field", "image"]) == 0
    captured = capsys.readouterr()
    assert _records(captured.out)[0][1]["height"] == 2  # type: ignore[index]
    assert captured.err.startswith(
        "pyconnect: warning: cannot decode the image (shown as its fields): "
    )
