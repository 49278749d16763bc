"""``pyconnect.record.bag_read``: a read's messages, its errors, and topics that change decoder."""

from __future__ import annotations

import struct
from pathlib import Path

from pyconnect.record import open_bag
from pyconnect.record.topic_decoder import IN_A_ROW
from tests.record.test_topic_decoder import FOXY_RANGE, TWO_STRINGS, foxy_range, strings_cdr


def _mcap(path: Path, msg_type: str, definition: str, messages: list[bytes]) -> Path:
    """An MCAP file of topic /t storing ``definition`` for ``msg_type`` (no type hash, as
    older tools write), one message per microsecond."""
    from mcap.writer import Writer

    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema(msg_type, "ros2msg", definition.encode())
        channel = writer.register_channel("/t", "cdr", schema)
        for time, data in enumerate(messages, 1):
            writer.add_message(channel, log_time=1_000 * time, data=data, publish_time=time)
        writer.finish()
    return path


def test_a_damaged_message_keeps_the_stored_definition_for_the_intact_ones(
    tmp_path: Path,
) -> None:
    messages = [foxy_range(i) for i in range(11)]
    messages[5] += b"\x01\x02\x03\x04"  # the installed Range would read them as `variance`
    bag = _mcap(tmp_path / "foxy.mcap", "sensor_msgs/msg/Range", FOXY_RANGE, messages)
    with open_bag(bag, natural=False) as reader:
        values = [message.value for message in reader]
        assert [(problem.topic, problem.index) for problem in reader.errors] == [("/t", 5)]
        assert reader.switched == {}
    assert [value["range"] for value in values] == [1.0 + i for i in range(11) if i != 5]
    assert not any("variance" in value for value in values)


def test_a_refused_natural_value_is_an_error_not_the_installed_layout(tmp_path: Path) -> None:
    data = b"\x00\x01\x00\x00" + struct.pack("<f", 1.5)
    bag = _mcap(tmp_path / "int.mcap", "std_msgs/msg/Int32", "float32 data", [data, data])
    with open_bag(bag) as reader:
        assert list(reader) == []  # not 1069547520, the bits of 1.5 read as int32
        assert [(problem.index, problem.reason) for problem in reader.errors] == [
            (0, "Int32.data: expected int, got float"),
            (1, "Int32.data: expected int, got float"),
        ]


def test_misfits_in_a_row_switch_the_topic_and_say_after_how_many(tmp_path: Path) -> None:
    later = [strings_cdr(str(i)) for i in range(IN_A_ROW + 1)]
    messages = [strings_cdr("a", "x"), strings_cdr("b", "y"), *later]
    bag = _mcap(tmp_path / "s.mcap", "std_msgs/msg/String", TWO_STRINGS, messages)
    with open_bag(bag, natural=False) as reader:
        values = [message.value for message in reader]
        assert [problem.index for problem in reader.errors] == list(range(2, 1 + IN_A_ROW))
        assert reader.switched == {"/t": 2}
    assert values[:2] == [{"data": "a", "extra": "x"}, {"data": "b", "extra": "y"}]
    assert values[2:] == [{"data": str(IN_A_ROW - 1)}, {"data": str(IN_A_ROW)}]


def test_a_wrong_definition_gives_way_though_the_topic_has_other_connections(
    tmp_path: Path,
) -> None:
    """Another connection's messages (another type of the topic, or the same type in a bag
    read with it) fit their own definitions: counted as this definition's, they kept the wrong
    one in place and every message of its connection was lost."""
    good = _mcap(tmp_path / "good.mcap", "std_msgs/msg/String", "string data",
                 [strings_cdr(f"g{i}") for i in range(3)])  # fmt: skip
    wrong = _mcap(tmp_path / "wrong.mcap", "std_msgs/msg/String", TWO_STRINGS,
                  [strings_cdr(f"w{i}") for i in range(3)])  # fmt: skip
    with open_bag([good, wrong], natural=False) as reader:
        values = [message.value["data"] for message in reader]
        assert reader.errors == []
    assert sorted(values) == ["g0", "g1", "g2", "w0", "w1", "w2"]
