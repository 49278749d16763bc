"""``align``: bag topics matched by header stamp as message_filters' ApproximateTimeSynchronizer."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from sensor_msgs.msg import Image, JointState
from std_msgs.msg import String

from pyconnect.record import align, open_bag
from pyconnect.record.align import align_table, match_stamps
from pyconnect.record.mcap_recorder import McapRecorder
from tests.conftest import require_sample_bags
from tests.record.bag_samples import BAGS
from tests.record.table_bags import stamp_of, write_bag

T0 = 1_700_000_000_000_000_000
MS = 1_000_000


def _image(stamp_ns: int, level: int) -> Image:
    msg = Image(height=1, width=2, encoding="mono8", step=2, data=bytes([level, level]))
    msg.header.stamp.sec, msg.header.stamp.nanosec = stamp_of(stamp_ns)
    return msg


def _joints(stamp_ns: int, position: float) -> JointState:
    msg = JointState(name=["elbow"], position=[position])
    msg.header.stamp.sec, msg.header.stamp.nanosec = stamp_of(stamp_ns)
    return msg


def _position(frame: int, offset_ms: int) -> float:
    return frame + offset_ms / 1000


# Camera every 100 ms (stamps k*100 ms); joints with known offsets from each camera frame.
# Each message is logged 1 ms after its stamp, so the bag order is the stamp order.
JOINT_OFFSETS_MS = {
    0: [15],  # one joint 15 ms late: matched at tolerance 0.02
    1: [-18, 5],  # -18 ms arrives before the frame, +5 ms after: the frame takes -18 (greedy)
    2: [25],  # 25 ms: outside 0.02, never matched
    3: [-4, 30],  # -4 ms matched; +30 ms left over
    4: [],  # no joint: the frame is dropped
}


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    messages: list[tuple[int, str, object]] = []
    for k, offsets in JOINT_OFFSETS_MS.items():
        frame = T0 + k * 100 * MS
        messages.append((frame, "/camera/image_raw", _image(frame, k)))
        for offset in offsets:
            stamp = frame + offset * MS
            messages.append((stamp, "/joint_states", _joints(stamp, _position(k, offset))))
        messages.append((frame + 50 * MS, "/chatter", String(data=f"frame {k}")))
    messages.sort(key=lambda entry: entry[0])
    return write_bag(
        tmp_path_factory.mktemp("align") / "bag",
        [(topic, stamp + MS, msg) for stamp, topic, msg in messages],
    )


def test_matches_follow_approximate_time_synchronizer(bag: Path) -> None:
    matches = list(align(bag, ["/camera/image_raw", "/joint_states"], tolerance=0.02))
    pairs = [(image.value[0, 0], joints.value["elbow"]["position"]) for image, joints in matches]
    assert pairs == [(0, _position(0, 15)), (1, _position(1, -18)), (3, _position(3, -4))]
    image, joints = matches[0]
    assert image.topic == "/camera/image_raw"
    assert isinstance(image.value, np.ndarray)
    assert joints.log_time_ns == T0 + 16 * MS


def test_natural_values_read_each_topics_first_message_once(
    bag: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Settling a topic's codec would read its first message again: align needs none, as
    each message comes with the codec it was decoded with."""
    from pyconnect.record.bag_reader import BagReader

    settled: list[object] = []
    real = BagReader._settle

    def counting(self: BagReader, decoder: object, *args: object) -> None:
        settled.append(decoder)
        real(self, decoder, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(BagReader, "_settle", counting)
    matches = list(align(bag, ["/camera/image_raw", "/joint_states"], tolerance=0.02))
    assert len(matches) == 3
    assert settled == []


def test_a_tighter_tolerance_matches_other_pairs(bag: Path) -> None:
    matches = list(align(bag, ["/camera/image_raw", "/joint_states"], tolerance=0.01))
    # frame 1 is still queued (-18 ms is too far) when the +5 ms joint arrives
    pairs = [(image.value[0, 0], joints.value["elbow"]["position"]) for image, joints in matches]
    assert pairs == [(1, _position(1, 5)), (3, _position(3, -4))]


def test_headerless_topics_use_the_log_time(bag: Path) -> None:
    matches = list(align(bag, ["/joint_states", "/chatter"], tolerance=0.03, natural=False))
    # /chatter has no header: its time is its log time, k*100+51 ms; the joints' times are their
    # stamps, k*100+offset ms. Within 30 ms: +25 ms (frame 2) and +30 ms (frame 3).
    assert [(joints.value["position"][0], chat.value["data"]) for joints, chat in matches] == [
        (_position(2, 25), "frame 2"),
        (_position(3, 30), "frame 3"),
    ]


def test_align_table_holds_each_topics_columns(bag: Path) -> None:
    table = align_table(bag, ["/camera/image_raw", "/joint_states"], tolerance=0.02)
    assert table.num_rows == 3
    assert table.column("/joint_states.position").to_pylist() == [
        [_position(0, 15)],
        [_position(1, -18)],
        [_position(3, -4)],
    ]
    assert table.column("/camera/image_raw.header.stamp.nanosec").to_pylist() == [
        stamp_of(T0 + k * 100 * MS)[1] for k in (0, 1, 3)
    ]


def test_queue_size_drops_the_oldest() -> None:
    arrivals = [(0, 0, "a0"), (0, 10, "a1"), (1, 1, "b0")]
    assert list(match_stamps(arrivals, topics=2, tolerance_ns=5, queue_size=2)) == [("a0", "b0")]
    assert list(match_stamps(arrivals, topics=2, tolerance_ns=5, queue_size=1)) == []


def test_equally_near_candidates_match_in_the_order_they_arrived() -> None:
    """message_filters sorts a queue's candidates by their distance alone, stably: of two
    equally near, the one queued first matches (the smaller stamp was taken before)."""
    arrivals = [(1, 110, "b110"), (1, 90, "b90"), (0, 100, "a")]
    assert list(match_stamps(arrivals, topics=2, tolerance_ns=20)) == [("a", "b110")]
    arrivals = [(1, 90, "b90"), (1, 110, "b110"), (0, 100, "a")]
    assert list(match_stamps(arrivals, topics=2, tolerance_ns=20)) == [("a", "b90")]


def test_three_topics_need_all_within_the_tolerance() -> None:
    arrivals = [(0, 100, "a"), (1, 104, "b"), (2, 96, "c1"), (2, 99, "c2")]
    # c1 is within 5 of b's arrival? no: only a and b are queued when c1 arrives: 100, 104, 96
    # spans 8; c2 gives 100, 104, 99: spans 5, not < 5; so nothing. Tolerance 6 takes c2.
    assert list(match_stamps(arrivals, topics=3, tolerance_ns=5)) == []
    assert list(match_stamps(arrivals, topics=3, tolerance_ns=6)) == [("a", "b", "c2")]


def test_bad_arguments_are_errors(bag: Path) -> None:
    with pytest.raises(ValueError) as raised:
        next(align(bag, ["/joint_states"], tolerance=0.02))
    assert (
        str(raised.value) == "topics: expected two or more different topics, got ['/joint_states']"
    )
    with pytest.raises(ValueError) as raised:
        next(align(bag, ["/a", "/b"], tolerance=0))
    assert str(raised.value) == "tolerance: expected seconds > 0, got 0"


TOO_LONG = "tolerance: expected seconds < 9223372036.854776 (int64 nanoseconds), got "


@pytest.mark.parametrize(
    ("tolerance", "error", "message"),
    [
        ("0.1", TypeError, "tolerance: expected seconds (a real number) > 0, got str ('0.1')"),
        (None, TypeError, "tolerance: expected seconds (a real number) > 0, got NoneType (None)"),
        (True, TypeError, "tolerance: expected seconds (a real number) > 0, got bool (True)"),
        (-1, ValueError, "tolerance: expected seconds > 0, got -1"),
        (float("nan"), ValueError, "tolerance: expected seconds > 0, got nan"),
        (float("inf"), ValueError, "tolerance: expected finite seconds, got inf"),
        # Finite, but too many nanoseconds for int64 (they overflowed round() to inf before).
        (1e300, ValueError, f"{TOO_LONG}1e+300"),
        (np.float32(1e30), ValueError, f"{TOO_LONG}np.float32(1e+30)"),
        pytest.param(10**400, ValueError, f"{TOO_LONG}{str(10**400)[:80]}", id="10**400"),
        (2**63 / 1e9, ValueError, f"{TOO_LONG}9223372036.854776"),
    ],
)
def test_a_bad_tolerance_is_refused_at_the_call(
    bag: Path, tolerance: object, error: type[Exception], message: str
) -> None:
    topics = ["/camera/image_raw", "/joint_states"]
    for function in (align, align_table):
        with pytest.raises(error) as raised:
            function(bag, topics, tolerance=tolerance)  # type: ignore[operator]
        assert str(raised.value) == message
    with pytest.raises(TypeError) as raised:
        align(bag, topics, tolerance=0.02, queue_size="3")  # type: ignore[arg-type]
    assert str(raised.value) == "queue_size: expected an int >= 1, got str"
    # A real number of another type is seconds too.
    assert len(list(align(bag, topics, tolerance=np.float32(0.02)))) == len(
        list(align(bag, topics, tolerance=0.02))
    )


def test_a_message_trimmed_from_its_own_queue_matches_nothing() -> None:
    # /a's queue holds 20 and 30; the late stamp 5 is the oldest, so it leaves at once: the /b
    # message at 5 stays unmatched, as message_filters' ApproximateTimeSynchronizer leaves it.
    arrivals = [(1, 5, "b5"), (0, 20, "a20"), (0, 30, "a30"), (0, 5, "a5")]
    assert list(match_stamps(arrivals, topics=2, tolerance_ns=1, queue_size=2)) == []
    assert list(match_stamps(arrivals, topics=2, tolerance_ns=1, queue_size=3)) == [("a5", "b5")]


# A type only the bag defines (my_pkg is not installed): natural values come from its definition.
STAMPED = (
    "std_msgs/Header header\nfloat64 v\n"
    "================================================================================\n"
    "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
    "================================================================================\n"
    "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
)


def _stamped(sec: int, v: float) -> bytes:
    # header.stamp (sec, nanosec), frame_id "" (length 1, its NUL), padding to 8, then v.
    return b"\x00\x01\x00\x00" + struct.pack("<iIIB3xd", sec, 0, 1, 0, v)


def test_natural_values_of_a_type_only_the_bag_defines(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    with McapRecorder(bag) as recorder:
        for topic in ("/a", "/b"):
            recorder.add_topic(topic, "my_pkg/msg/Stamped", definition=STAMPED)
        for i in range(3):
            recorder.write("/a", _stamped(i, 1.5 * i), log_time_ns=10 * i + 1)
            recorder.write("/b", _stamped(i, -1.5 * i), log_time_ns=10 * i + 2)
    with open_bag(bag) as reader:
        expected = [m.value for m in reader]
    pairs = list(align(bag, ["/a", "/b"], tolerance=0.1))
    assert [m.value for pair in pairs for m in pair] == expected
    assert [m.msg_type for m in pairs[0]] == ["my_pkg/msg/Stamped"] * 2


def test_natural_values_of_an_old_definition_are_the_bags(tmp_path: Path) -> None:
    # A Foxy sensor_msgs/Range has no `variance`: align must not invent one.
    foxy = BAGS / "rosbags_rs/test_bag_sqlite3"
    require_sample_bags(foxy, foxy.exists())
    topics = ["/test/sensor_msgs/range", "/test/sensor_msgs/temperature"]
    with open_bag(foxy, topics=topics) as reader:
        expected = {(m.topic, m.log_time_ns): m.value for m in reader}
    pairs = list(align(foxy, topics, tolerance=1.0))
    assert pairs
    for pair in pairs:
        for message in pair:
            assert message.value == expected[message.topic, message.log_time_ns]
    assert "variance" not in pairs[0][0].value


def _thing(text: str, extra: int | None = None) -> bytes:
    """CDR of my_pkg/msg/Thing: ``string data``, then ``int32 extra`` in its second definition."""
    data = text.encode() + b"\0"
    body = struct.pack("<I", len(data)) + data
    if extra is not None:
        body += b"\0" * (-len(body) % 4) + struct.pack("<i", extra)
    return b"\x00\x01\x00\x00" + body


def test_a_topic_stored_with_two_definitions_gets_each_messages_own(tmp_path: Path) -> None:
    """/t has two channels of my_pkg/msg/Thing, the second with a field more: each matched
    message goes back to CDR through its own channel's codec (the first's lacks ``extra``)."""
    from mcap.writer import Writer

    bag = tmp_path / "two_definitions.mcap"
    with bag.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        string = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data\n")
        old = writer.register_schema("my_pkg/msg/Thing", "ros2msg", b"string data\n")
        new = writer.register_schema("my_pkg/msg/Thing", "ros2msg", b"string data\nint32 extra\n")
        s = writer.register_channel("/s", "cdr", string)
        t_old = writer.register_channel("/t", "cdr", old)
        t_new = writer.register_channel("/t", "cdr", new)
        for i in range(4):
            time = (i + 1) * 1_000_000_000
            writer.add_message(s, time, _thing(f"s{i}"), time)
            thing = _thing(f"a{i}") if i < 2 else _thing(f"b{i}", 40 + i)
            writer.add_message(t_old if i < 2 else t_new, time, thing, time)
        writer.finish()
    with open_bag(bag) as reader:
        expected = [(m.topic, m.value) for m in reader]
    for natural in (True, False):
        pairs = list(align(bag, ["/s", "/t"], tolerance=0.1, natural=natural))
        values = [(m.topic, m.value) for pair in pairs for m in pair]
        if natural:
            assert values == expected
        assert [m.value for _s, m in pairs] == [
            {"data": "a0"},
            {"data": "a1"},
            {"data": "b2", "extra": 42},
            {"data": "b3", "extra": 43},
        ]
