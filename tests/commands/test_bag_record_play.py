"""``pyconnect bag record`` and ``bag play`` against plain rclpy peers; Ctrl-C leaves a valid bag."""

from __future__ import annotations

import json
import re
import signal
import time
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader
from std_msgs.msg import String

from pyconnect.cli import main
from pyconnect.commands.bag_play import Lateness, offered_qos
from pyconnect.record import open_bag
from pyconnect.record.mcap_recorder import McapRecorder
from tests.commands.processes import WAIT, Lines, spawn


def _split_order(name: str) -> int:
    match = re.fullmatch(r"run1_(\d+)\.mcap", name)
    assert match, name
    return int(match.group(1))


def _check_bag(bag: Path) -> list[tuple[str, object]]:
    """Every file finished and listed in order, every reader agrees; the messages read."""
    # run1_10.mcap comes after run1_9.mcap (a name sort put it third and failed a loaded run)
    files = sorted((p.name for p in bag.glob("*.mcap")), key=_split_order)
    assert len(files) >= 2  # a new file after each message of at least 1 byte
    with open_bag(bag) as reader:
        ours = [(m.topic, m.value) for m in reader]
        assert (reader.errors, reader.damage) == ([], [])
    assert all(re.fullmatch(r"hello \d+", v) for t, v in ours if t == "/chatter")  # type: ignore[arg-type]
    with AnyReader([bag]) as theirs:
        assert sum(1 for _ in theirs.messages()) == len(ours)
    decoded = 0
    for name in files:
        with open(bag / name, "rb") as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            assert reader.get_summary() is not None, name  # finished, not cut short
            decoded += sum(1 for _ in reader.iter_decoded_messages())
    assert decoded == len(ours)
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert metadata["relative_file_paths"] == files
    assert [f["path"] for f in metadata["files"]] == files
    assert metadata["message_count"] == len(ours)
    assert sum(f["message_count"] for f in metadata["files"]) == len(ours)
    return ours


# SIGTERM too: systemd, docker stop and timeout stop a recorder with it, and the bag must be whole.
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_record_until_ctrl_c_writes_a_bag_every_reader_reads(
    peer: Lines, tmp_path: Path, signum: int
) -> None:
    bag = tmp_path / "run1"
    recorder = spawn(
        "-m", "pyconnect.cli", "bag", "record", "/chatter", "/image", "-o", str(bag),
        "--max-bag-size", "1",
    )  # fmt: skip
    lines = Lines(recorder)
    try:
        lines.wait_for("^Recording '/chatter': first message received$")
        lines.wait_for("^Recording '/image': first message received$")
    finally:
        err = lines.stop(signum)
    assert (recorder.returncode, err) == (0, "")
    ours = _check_bag(bag)
    assert {topic for topic, _value in ours} == {"/chatter", "/image"}
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    chatter = metadata["topics_with_message_count"][0]["topic_metadata"]
    assert yaml.safe_load(chatter["offered_qos_profiles"])[0]["reliability"] == 1  # reliable


@pytest.mark.parametrize("split_at", [2, 12])
def test_ctrl_c_at_a_split_and_again_while_finishing_loses_no_file(
    peer: Lines, tmp_path: Path, split_at: int
) -> None:
    """SIGINT is sent from inside the split-th file's opening (on the writer thread), and a
    second one from inside the bag's closing (tests/commands/interrupted_record.py): the bag is
    still whole."""
    bag = tmp_path / "run1"
    recorder = spawn(
        "-m", "tests.commands.interrupted_record", str(split_at),
        "bag", "record", "/chatter", "/image", "-o", str(bag), "--max-bag-size", "1",
    )  # fmt: skip
    out, err = recorder.communicate(timeout=WAIT)
    assert (recorder.returncode, err) == (0, ""), out
    ours = _check_bag(bag)
    # The split still happened; messages received before the recording stopped came after it
    # (the writer thread writes them all), one file each.
    assert len(list(bag.glob("*.mcap"))) >= split_at
    assert out.splitlines()[-1] == f"Recorded {len(ours)} message(s) to '{bag}'"


def test_record_needs_topics_or_all(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bag", "record", "-o", str(tmp_path / "x")]) == 1
    assert capsys.readouterr().err == "pyconnect: error: give either -a or the topics to record\n"


BEST_EFFORT_LATCHED = yaml.safe_dump(
    [{"history": 1, "depth": 1, "reliability": 2, "durability": 1}], sort_keys=False
)


@pytest.fixture(scope="module")
def played_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    bag = tmp_path_factory.mktemp("play") / "bag"
    start = 1_700_000_000_000_000_000
    with McapRecorder(bag) as recorder:
        recorder.add_topic(
            "/played", "std_msgs/msg/String", offered_qos_profiles=BEST_EFFORT_LATCHED
        )
        for k in range(20):
            data = serialize_message(String(data=f"played {k}"))
            recorder.write("/played", data, log_time_ns=start + k * 50_000_000)
    return bag


# The bag's directory, and its .mcap file alone: QoS came from metadata.yaml only, so a bare
# file played a latched topic volatile (the file's channel metadata stores the same QoS).
@pytest.mark.parametrize("given", ["directory", "file"])
def test_play_republishes_with_the_bags_qos_and_clock(
    played_bag: Path, capsys: pytest.CaptureFixture[str], given: str
) -> None:
    path = played_bag if given == "directory" else next(played_bag.glob("*.mcap"))
    player = spawn("-m", "pyconnect.cli", "bag", "play", str(path), "--loop", "--clock")
    lines = Lines(player)
    try:
        lines.wait_for("^Playing ")
        assert main(["topic", "echo", "/played", "--once", "--timeout", str(WAIT), "--json"]) == 0
        assert re.fullmatch(r'"played \d+"\n', capsys.readouterr().out)
        assert main(["topic", "echo", "/clock", "--once", "--timeout", str(WAIT), "--json"]) == 0
        clock = json.loads(capsys.readouterr().out)
        assert clock["clock"]["sec"] == 1_700_000_000
        # info spins its whole --spin-time: asked again until discovery has found the player.
        deadline = time.monotonic() + WAIT
        while True:
            status = main(["topic", "info", "/played", "-v"])  # 1 while not discovered yet
            info = capsys.readouterr().out.splitlines()
            if (status == 0 and "Publisher count: 1" in info) or time.monotonic() > deadline:
                break
        assert status == 0
        assert "  Reliability: BEST_EFFORT" in info
        assert "  Durability: TRANSIENT_LOCAL" in info
    finally:
        err = lines.stop()
    assert (player.returncode, err) == (0, "")


def test_play_reports_its_timing_error(
    played_bag: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Timing depends on the machine: the error is printed (and measured in the bench), not asserted.
    assert main(["bag", "play", str(played_bag), "--rate", "4", "--start-offset", "0.5"]) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert re.fullmatch(
        r"Played 10 message\(s\); timing error: mean -?\d+\.\d{3} ms, max -?\d+\.\d{3} ms", last
    )
    print(last)


def test_lateness_keeps_a_count_a_sum_and_the_worst() -> None:
    """``--loop`` kept one float per message played, for the mean at the end (1.85 MB/s)."""
    late = Lateness()
    for seconds in (0.002, -0.001, 0.005):
        late.add(seconds)
    assert (late.count, late.worst) == (3, 0.005)
    assert late.mean == pytest.approx(0.002)
    assert set(vars(late)) == {"count", "total", "worst"}


def test_offered_qos_from_metadata() -> None:
    profile = offered_qos(BEST_EFFORT_LATCHED)
    assert (profile.reliability.name, profile.durability.name) == ("BEST_EFFORT", "TRANSIENT_LOCAL")
    mixed = yaml.safe_dump(
        [{"reliability": 2, "durability": 2}, {"reliability": 1, "durability": 1}]
    )
    profile = offered_qos(mixed)
    assert (profile.reliability.name, profile.durability.name) == ("RELIABLE", "VOLATILE")
    assert offered_qos("").reliability.name == "RELIABLE"
    # A file's channel metadata is input too: nesting deep enough to overflow the YAML parser
    # (a RecursionError, not a YAMLError) ended bag play in a traceback.
    assert offered_qos("[" * 3000).reliability.name == "RELIABLE"


def test_play_leaves_out_a_topic_whose_type_is_not_installed(
    played_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # tf2_msgs is not in the wheels: a bag with /tf must still play its other topics.
    bag = tmp_path / "with_tf"
    with McapRecorder(bag) as recorder:
        recorder.add_topic("/played", "std_msgs/msg/String")
        recorder.add_topic("/tf", "nowhere_msgs/msg/Transforms", definition="int32 count\n")
        for k in range(3):
            recorder.write("/played", serialize_message(String(data=f"{k}")), log_time_ns=k + 1)
            recorder.write("/tf", b"\x00\x01\x00\x00\x07\x00\x00\x00", log_time_ns=k + 1)
    assert main(["bag", "play", str(bag), "--rate", "1000"]) == 0
    captured = capsys.readouterr()
    assert captured.err.startswith(
        "pyconnect: warning: not playing /tf: nowhere_msgs/msg/Transforms: "
        "no such interface is installed"
    )
    assert captured.out.splitlines()[0] == f"Playing {bag} (1 topic(s))"
    assert captured.out.splitlines()[-1].startswith("Played 3 message(s)")


def test_play_of_a_damaged_bag_plays_what_it_can_then_exits_1(
    played_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mcap = next(played_bag.glob("*.mcap"))
    cut = tmp_path / "cut.mcap"
    data = mcap.read_bytes()
    cut.write_bytes(data[: len(data) - 100])  # inside the summary: the messages are intact
    assert main(["bag", "play", str(cut), "--rate", "1000"]) == 1
    captured = capsys.readouterr()
    assert captured.out.splitlines()[-1].startswith("Played 20 message(s)")
    assert captured.err.startswith(f"pyconnect: {cut}: damaged bag: {cut} at byte")
    assert main(["bag", "play", str(cut), "--rate", "1000", "--ignore-damage"]) == 0
    assert "damaged bag" in capsys.readouterr().err


def test_record_resolves_relative_topic_names_as_rosbag2_does() -> None:
    from pyconnect.cli import build_parser

    args = build_parser().parse_args(["bag", "record", "chatter", "/image", "-o", "run"])
    assert args.topics == ["/chatter", "/image"]
