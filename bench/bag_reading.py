"""Bag reading speed: every message of the robot_localization bags decoded to values.

Ours (``open_bag``, natural values and lossless dicts) against rosbags (``AnyReader`` +
``deserialize_cdr``) and mcap-ros2-support (``iter_decoded_messages``), on the same files in the
same run; best of a few rounds each. Run: ``python -m bench.bag_reading``.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Callable
from pathlib import Path

BAGS = (Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "bags").resolve()
BAG_DIRS = [
    BAGS / "robot_localization_converted" / "test1_ros2_mcap_zstd",
    BAGS / "robot_localization_converted" / "test2_ros2_mcap_zstd",
]
ROUNDS = 3


def read_ours(natural: bool) -> int:
    from pyconnect.record.bag_reader import open_bag

    count = 0
    for bag_dir in BAG_DIRS:
        with open_bag(bag_dir, natural=natural) as bag:
            for _message in bag:
                count += 1
            if bag.errors:
                raise RuntimeError(f"{bag_dir}: {len(bag.errors)} messages not decoded")
    return count


def read_rosbags() -> int:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_JAZZY)
    count = 0
    with AnyReader(BAG_DIRS, default_typestore=typestore) as reader:
        for connection, _, raw in reader.messages():
            reader.deserialize(raw, connection.msgtype)  # AnyReader's deserialize_cdr
            count += 1
    return count


def read_mcap_ros2() -> int:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    count = 0
    for bag_dir in BAG_DIRS:
        for path in sorted(bag_dir.glob("*.mcap")):
            with path.open("rb") as stream:
                reader = make_reader(stream, decoder_factories=[DecoderFactory()])
                for _ in reader.iter_decoded_messages():
                    count += 1
    return count


def best_rate(read: Callable[[], int]) -> tuple[int, float]:
    best = float("inf")
    count = 0
    for _ in range(ROUNDS):
        gc.collect()
        start = time.perf_counter()
        count = read()
        best = min(best, time.perf_counter() - start)
    return count, count / best


def main() -> None:
    read_ours(True)  # compile and cache the codecs once, as any long read would
    rows = [
        ("pyconnect open_bag (natural values)", best_rate(lambda: read_ours(True))),
        ("pyconnect open_bag (lossless dicts)", best_rate(lambda: read_ours(False))),
        ("rosbags AnyReader + deserialize_cdr", best_rate(read_rosbags)),
        ("mcap-ros2-support iter_decoded_messages", best_rate(read_mcap_ros2)),
    ]
    counts = {count for _, (count, _) in rows}
    if len(counts) != 1:
        raise RuntimeError(f"readers disagree on the message count: {counts}")
    rosbags_rate = rows[2][1][1]
    mcap_rate = rows[3][1][1]
    print(f"Reading {counts.pop()} messages of {len(BAG_DIRS)} bags, best of {ROUNDS}")
    print(f"{'reader':<42} {'msgs/s':>10} {'vs rosbags':>11} {'vs mcap-ros2':>13}")
    for name, (_, rate) in rows:
        print(f"{name:<42} {rate:>10,.0f} {rate / rosbags_rate:>10.2f}x {rate / mcap_rate:>12.2f}x")
    print("target: pyconnect >= 1.5x both")


if __name__ == "__main__":
    main()
