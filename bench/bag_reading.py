"""Bag reading speed: every message of the robot_localization bags decoded to values.

Ours (``open_bag``, natural values and lossless dicts) against rosbags (``AnyReader`` +
``deserialize_cdr``) and mcap-ros2-support (``iter_decoded_messages``), on the same files in the
same run; best of a few rounds each. Run: ``python -m bench.bag_reading``.
"""

from __future__ import annotations

import gc
import os
import statistics
import subprocess
import sys
import tempfile
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


# -- cold start: each case in a fresh process -----------------------------------------------------
COLD_ROUNDS = 3
FRESH_READ_ROUNDS = 5
COLD_TYPES = ("sensor_msgs/msg/Imu", "nav_msgs/msg/Odometry", "sensor_msgs/msg/NavSatFix")
_FIRST_DECODE = """
import sys, time
started = time.perf_counter()
from pyconnect.codecs import wire
value = wire.decode(bytes.fromhex(sys.argv[2]), sys.argv[1])
print(time.perf_counter() - started)
"""
_FRESH_READ = """
import sys, time
started = time.perf_counter()
sys.path.insert(0, sys.argv[2])
from bench import bag_reading
count = bag_reading.read_ours(True) if sys.argv[1] == "ours" else bag_reading.read_rosbags()
print(count / (time.perf_counter() - started))
"""


def _child(code: str, *args: str, cache: str) -> float:
    # Bytecode compiled once into a cache of the bench's own, as an installed package has it
    # (pip compiles it at install); PYTHONDONTWRITEBYTECODE would make every child compile the
    # sources again, which measures the compiler, not the import.
    env = {**os.environ, "PYTHONPYCACHEPREFIX": cache}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    done = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True,
                          text=True, check=True, timeout=600)  # fmt: skip
    return float(done.stdout.split()[-1])


def cold_start() -> None:
    """Import plus first decode, and a whole bag read, each in a fresh process (medians)."""
    samples: dict[str, bytes] = {}
    from pyconnect.record.bag_reader import open_bag

    with open_bag(BAG_DIRS[0], raw=True) as bag:
        for message in bag:
            samples.setdefault(message.msg_type, message.value)
    root = str(Path(__file__).resolve().parents[1])
    with tempfile.TemporaryDirectory(prefix="pyconnect-pyc-") as cache:
        for msg_type in COLD_TYPES:  # compile the bytecode of every path once
            _child(_FIRST_DECODE, msg_type, samples[msg_type].hex(), cache=cache)
        _child(_FRESH_READ, "rosbags", root, cache=cache)
        print(f"\nCold start: each case in a fresh process, median of {COLD_ROUNDS} "
              f"({FRESH_READ_ROUNDS} in turns for the whole read)")  # fmt: skip
        print(f"  {'case':<52} {'value':>12}")
        for msg_type in COLD_TYPES:
            times = [_child(_FIRST_DECODE, msg_type, samples[msg_type].hex(), cache=cache)
                     for _ in range(COLD_ROUNDS)]  # fmt: skip
            label = f"import pyconnect.codecs.wire + decode {msg_type.rsplit('/', 1)[-1]}"
            print(f"  {label:<52} {statistics.median(times) * 1e3:>9.0f} ms")
        # The two readers take turns, so a slow patch of the machine costs both alike.
        runs: dict[str, list[float]] = {"ours": [], "rosbags": []}
        for _ in range(FRESH_READ_ROUNDS):
            for reader, rates_of_reader in runs.items():
                rates_of_reader.append(_child(_FRESH_READ, reader, root, cache=cache))
        rates = {reader: statistics.median(values) for reader, values in runs.items()}
        for reader, label in (("ours", "pyconnect open_bag"), ("rosbags", "rosbags AnyReader")):
            name = f"fresh process reads both bags: {label}"
            print(f"  {name:<52} {rates[reader]:>8,.0f} msg/s "
                  f"{rates[reader] / rates['rosbags']:.2f}x")  # fmt: skip
    print("  target: import + first decode <= 200 ms; fresh-process read >= 1.5x rosbags")


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
    cold_start()


if __name__ == "__main__":
    main()
