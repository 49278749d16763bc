"""Every sample bag in ../shared/data/bags: counts, decoding, and values equal to rosbags'."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pytest

from pyconnect.errors import DecodeError
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_reader import bag_info, open_bag
from tests.conftest import require_sample_bags
from tests.record.bag_samples import (
    BAGS,
    expected_bags,
    plain,
    reference_decoded,
    same_as_rosbags,
)

EXPECTED = expected_bags()
require_sample_bags(BAGS, bool(EXPECTED))

WRONG_FORMAT = sorted(key for key in EXPECTED if key.endswith("wrong_rmw_test"))
READABLE = sorted(key for key in EXPECTED if key not in WRONG_FORMAT)
SYNTHETIC = ("rosbags_rs/test_bag_mcap", "rosbags_rs/test_bag_sqlite3")
# The rosbags_rs synthetic Image holds fewer bytes than step x height (no ndarray can view it),
# and its CompressedImage holds only the first 10 bytes of a JPEG: neither has a natural value.
NOT_NATURAL = {
    "/test/sensor_msgs/image": "Image.data: expected at least 921600 bytes "
    "(step 1920 \N{MULTIPLICATION SIGN} height 480), got 30",
    "/test/sensor_msgs/compressed_image": "CompressedImage.data: cannot decode 10 bytes as jpeg",
}


@pytest.mark.parametrize("key", sorted(EXPECTED))
def test_message_counts_match_expected(key: str) -> None:
    info = bag_info(BAGS / key)
    counts = {topic.name: topic.message_count for topic in info.topics}
    types = {topic.name: topic.msg_type for topic in info.topics}
    for name, expected in EXPECTED[key]["topics"].items():
        assert counts[name] == expected["count"], name
        assert types[name] == expected["type"], name
    # Topics EXPECTED.json leaves out (declared, never published) hold no messages.
    assert {name: n for name, n in counts.items() if name not in EXPECTED[key]["topics"]} == {
        name: 0 for name in counts if name not in EXPECTED[key]["topics"]
    }
    assert info.message_count == sum(t["count"] for t in EXPECTED[key]["topics"].values())


@pytest.mark.parametrize("key", READABLE)
@pytest.mark.parametrize("natural", [True, False], ids=["natural", "dict"])
def test_every_message_decodes(key: str, natural: bool) -> None:
    decoded: dict[str, int] = {}
    with open_bag(BAGS / key, natural=natural) as bag:
        for message in bag:
            decoded[message.topic] = decoded.get(message.topic, 0) + 1
        errors = list(bag.errors)
    failed_topics = {problem.topic for problem in errors}
    if natural and key in SYNTHETIC:
        assert {(p.topic, p.reason) for p in errors} == set(NOT_NATURAL.items())
    else:
        assert errors == []
    for name, expected in EXPECTED[key]["topics"].items():
        must_decode = reference_decoded(expected) or "/srv/" in expected["type"]
        if must_decode and name not in failed_topics:
            assert decoded.get(name, 0) == expected["count"], name


@pytest.mark.parametrize("key", SYNTHETIC)
def test_short_image_is_reported_and_the_read_goes_on(
    key: str, caplog: pytest.LogCaptureFixture
) -> None:
    image = "/test/sensor_msgs/image"
    with caplog.at_level(logging.WARNING, logger="pyconnect.record"), open_bag(BAGS / key) as bag:
        topics_read = {message.topic for message in bag}
    assert len(topics_read) == 92
    assert [(p.topic, p.index) for p in bag.errors if p.topic == image] == [(image, 0), (image, 1)]
    assert f"4 message(s) not decoded ({sorted(NOT_NATURAL)[0]}: 2, {image}: 2)" in caplog.text
    with (
        pytest.raises(DecodeError) as caught,
        open_bag(BAGS / key, topics=[image], on_error="raise") as bag,
    ):
        list(bag)
    assert str(caught.value) == f"{BAGS / key}: {image}[0]: {NOT_NATURAL[image]}"


@pytest.mark.parametrize("key", WRONG_FORMAT)
def test_wrong_serialization_format_is_rejected(key: str) -> None:
    with pytest.raises(BagError) as caught:
        open_bag(BAGS / key, topics=["/array_topic"])
    assert str(caught.value) == (
        f"{BAGS / key}: topic /array_topic is serialised as 'wrong_format'; "
        "only 'cdr' can be decoded (raw=True reads it undecoded)"
    )
    # Selected by no topics=, it is left out and said to be, as other bags read on.
    with open_bag(BAGS / key) as bag:
        assert list(bag) == []
        assert bag.topics == {}
        assert bag.left_out == {t.name: "serialised as 'wrong_format'" for t in bag.info.topics}
    info = bag_info(BAGS / key)
    assert {t.serialization_format for t in info.topics} == {"wrong_format"}


SERVICE_EVENT_BAGS = sorted(
    key
    for key in READABLE
    if any("/srv/" in t["type"] and t["count"] for t in EXPECTED[key]["topics"].values())
)


@pytest.mark.parametrize("key", SERVICE_EVENT_BAGS)
def test_service_events_decode(key: str) -> None:
    with open_bag(BAGS / key, natural=False) as bag:
        events = [m for m in bag if "/srv/" in m.msg_type]
    assert events
    for event in events:
        assert set(event.value) == {"info", "request", "response"}
        assert isinstance(event.value["request"], list)
        assert len(event.value["request"]) + len(event.value["response"]) >= 1


def test_foxy_range_decodes_with_the_stored_definition() -> None:
    with open_bag(BAGS / "rosbags_rs/test_bag_sqlite3", topics=["/test/sensor_msgs/range"]) as bag:
        values = [m.value for m in bag]
    assert len(values) == 2
    with open_bag(
        BAGS / "rosbags_rs/test_bag_sqlite3", topics=["/test/sensor_msgs/range"], natural=False
    ) as bag:
        dicts = [m.value for m in bag]
    assert "variance" not in dicts[0]
    assert {"radiation_type", "field_of_view", "min_range", "max_range", "range"} <= set(dicts[0])


def test_type_without_msg_namespace_decodes() -> None:
    key = "ros2_rosbag2_jazzy/rosbag2_transport/test/resources/mcap/test_bag_for_seek"
    with open_bag(BAGS / key, natural=False) as bag:
        messages = list(bag)
    assert [m.msg_type for m in messages] == ["test_msgs/msg/BasicTypes"] * 5
    assert "int32_value" in messages[0].value


def _rosbags_messages(path: Path, limit: int) -> dict[tuple[str, int], list[Any]]:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    found: dict[tuple[str, int], list[Any]] = {}
    per_topic: dict[str, int] = {}
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        for connection, stamp, raw in reader.messages():
            seen = per_topic.get(connection.topic, 0)
            if seen >= limit:
                continue
            try:
                value = reader.deserialize(raw, connection.msgtype)
            except Exception:
                continue
            per_topic[connection.topic] = seen + 1
            found.setdefault((connection.topic, stamp), []).append(plain(value))
    return found


CROSS_CHECKED = sorted(
    key
    for key in READABLE
    if EXPECTED[key]["kind"] == "dir"
    and "rosbags_error" not in EXPECTED[key]
    and any(
        reference_decoded({"rosbags": t.get("rosbags", "0 ok/")})
        for t in EXPECTED[key]["topics"].values()
    )
)


@pytest.mark.parametrize("key", CROSS_CHECKED)
def test_values_equal_rosbags(key: str) -> None:
    limit = 3
    reference = _rosbags_messages(BAGS / key, limit)
    compared = 0
    per_topic: dict[str, int] = {}
    with open_bag(BAGS / key, natural=False) as bag:
        for message in bag:
            seen = per_topic.get(message.topic, 0)
            candidates = reference.get((message.topic, message.log_time_ns))
            if seen >= limit or candidates is None:
                continue
            per_topic[message.topic] = seen + 1
            ours = plain(message.value)
            assert any(same_as_rosbags(ours, theirs) for theirs in candidates), (
                message.topic,
                seen,
            )
            compared += 1
    assert compared >= min(limit, 1) * len(reference) // limit


def test_offline_reading_needs_no_rclpy() -> None:
    import subprocess
    import sys

    script = (
        "import sys\n"
        "sys.modules['rclpy'] = None  # any import of rclpy now fails\n"
        "from pyconnect.record import open_bag\n"
        f"with open_bag({str(BAGS / 'rosbags_rs/test_bag_mcap')!r}) as bag:\n"
        "    count = sum(1 for _ in bag)\n"
        "print(count, len(bag.errors), sys.modules['rclpy'] is not None)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, check=False
    )
    assert (done.returncode, done.stdout) == (0, "184 4 False\n"), done.stderr


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_split_bag_without_metadata_reads_as_one(storage: str) -> None:
    directory = (
        f"ros2_rosbag2_jazzy/rosbag2_py/test/resources/{storage}/reindex_test_bags/multiple_files"
    )
    files = [key for key in EXPECTED if key.startswith(directory + "/")]
    expected = sum(EXPECTED[key]["topics"]["/chatter"]["count"] for key in files)
    info = bag_info(BAGS / directory)
    assert [p.name for p in info.files] == sorted(Path(key).name for key in files)
    assert info.message_count == expected == 3177
    with open_bag(BAGS / directory) as bag:
        stamps = [m.log_time_ns for m in bag]
    assert len(stamps) == expected
    assert stamps == sorted(stamps)
    assert bag.errors == []


def test_stored_definitions_of_installed_hashes_use_the_generated_code(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A topic whose stored hash (here from metadata.yaml) is the installed type's is decoded by
    the generated code, without compiling the stored text (the cost of a fresh process's read)."""
    from pyconnect.codecs.registry import Registry

    compiled: list[Any] = []
    compile_text = Registry._definition_wire_codec

    def counting(*args: Any, **kwargs: Any) -> Any:
        compiled.append(args)
        return compile_text(*args, **kwargs)

    monkeypatch.setattr(Registry, "_definition_wire_codec", counting)
    bag = BAGS / "robot_localization_converted" / "test2_ros2_mcap_zstd"
    with open_bag(bag, natural=False) as reader:
        count = sum(1 for _ in reader)
        assert reader.errors == []
    assert count == sum(topic.message_count for topic in bag_info(bag).topics)
    assert compiled == []
