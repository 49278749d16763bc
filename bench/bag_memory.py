"""Peak memory reading a big synthetic bag (``make bench-bag-memory``; not part of ``make bench``).

Writes a bag of ``--size-mb`` MB (default 2048) of 640x480 rgb8 images into a temporary
directory — an MCAP with its summary, the same MCAP cut short (no summary, no index: a
recording that crashed) and a sqlite3 ``.db3`` — then reads each in a fresh process with
pyconnect (natural values, and raw), rosbags' ``AnyReader`` and mcap-ros2-support, and prints
each reader's peak RSS beside the bound the issue sets: 2 x the largest chunk + the largest
message, over the process's RSS before reading (after imports).
"""

from __future__ import annotations

import argparse
import json
import sqlite3
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

CHUNK = 4 * 1024 * 1024
WIDTH, HEIGHT = 640, 480

# Each reader runs in a child: its baseline (after imports) and its peak RSS in bytes.
_CHILD = r"""
import json, sys
from pathlib import Path
kind, path = sys.argv[1], Path(sys.argv[2])

def rss(field="VmRSS:"):
    for line in open("/proc/self/status"):
        if line.startswith(field):
            return int(line.split()[1]) * 1024

if kind.startswith("pyconnect"):
    from pyconnect.record import open_bag
    import pyconnect.codecs.wire  # noqa: F401
elif kind == "rosbags":
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
else:
    from mcap_ros2.reader import read_ros2_messages
# Warm up without reading a message (imports, the summary, the Image codec), then measure.
if kind.startswith("pyconnect"):
    from pyconnect.codecs import wire
    open_bag(path).close()
    tiny = {"height": 1, "width": 1, "encoding": "rgb8", "step": 3, "data": b"abc"}
    wire.decode(wire.from_dict(tiny, "sensor_msgs/msg/Image"), "sensor_msgs/msg/Image")
base = rss()
count = 0
if kind == "pyconnect":
    with open_bag(path) as bag:
        for item in bag:
            count += 1
elif kind == "pyconnect-raw":
    with open_bag(path, raw=True) as bag:
        for item in bag:
            count += 1
elif kind == "rosbags":
    with AnyReader([path], default_typestore=store) as reader:
        for connection, stamp, raw in reader.messages():
            reader.deserialize(raw, connection.msgtype)
            count += 1
else:
    for message in read_ros2_messages(str(next(path.glob("*.mcap")) if path.is_dir() else path)):
        count += 1
# VmHWM, not ru_maxrss: after fork and exec, ru_maxrss still counts the parent's peak.
peak = rss("VmHWM:")
print(json.dumps({"base": base, "peak": peak, "count": count}))
"""


def _image_cdr(index: int) -> bytes:
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import Image

    image = Image(height=HEIGHT, width=WIDTH, encoding="rgb8", step=WIDTH * 3)
    # Noise, as camera images are to a compressor: the file is as big as its payload.
    image.data = np.random.default_rng(index).bytes(HEIGHT * WIDTH * 3)
    image.header.frame_id = "camera"
    return bytes(serialize_message(image))


def write_bags(root: Path, size_mb: int) -> tuple[Path, Path, Path, int]:
    """(MCAP bag dir, cut MCAP file, db3 bag dir, largest message size)."""
    from pyconnect.record.mcap_recorder import McapRecorder

    sample = _image_cdr(0)
    count = max(1, size_mb * 1024 * 1024 // len(sample))
    mcap_dir = root / "images"
    db3_dir = root / "images_db3"
    db3_dir.mkdir()
    db = sqlite3.connect(db3_dir / "images_db3_0.db3")
    db.execute(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
        "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL)"
    )
    db.execute(
        "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
        "timestamp INTEGER NOT NULL, data BLOB NOT NULL)"
    )
    db.execute("CREATE INDEX timestamp_idx ON messages (timestamp ASC)")
    db.execute("INSERT INTO topics VALUES (1, '/camera', 'sensor_msgs/msg/Image', 'cdr', '')")
    with McapRecorder(mcap_dir, compression="none", chunk_size=CHUNK) as recorder:
        recorder.add_topic("/camera", "sensor_msgs/msg/Image")
        for i in range(count):
            data = _image_cdr(i)
            stamp = 1_700_000_000_000_000_000 + i * 33_000_000
            recorder.write("/camera", data, log_time_ns=stamp)
            db.execute("INSERT INTO messages VALUES (NULL, 1, ?, ?)", (stamp, data))
            if i % 200 == 0:
                db.commit()
    db.commit()
    db.close()
    from pyconnect.record.bag_metadata import BagMetadata, TopicMetadata, write_metadata

    write_metadata(
        db3_dir / "metadata.yaml",
        BagMetadata(
            storage_identifier="sqlite3",
            relative_file_paths=("images_db3_0.db3",),
            topics=(TopicMetadata("/camera", "sensor_msgs/msg/Image", message_count=count),),
            starting_time_ns=1_700_000_000_000_000_000,
            duration_ns=(count - 1) * 33_000_000,
            message_count=count,
        ),
    )
    whole = mcap_dir / "images_0.mcap"
    cut = root / "cut.mcap"
    with whole.open("rb") as source, cut.open("wb") as target:
        size = whole.stat().st_size
        remaining = size - 100_000  # the summary and a little of the last chunk go
        while remaining > 0:
            block = source.read(min(remaining, 64 * 1024 * 1024))
            target.write(block)
            remaining -= len(block)
    return mcap_dir, cut, db3_dir, len(sample)


def _largest_chunk(path: Path) -> int:
    from mcap.reader import make_reader

    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    return max(index.uncompressed_size for index in summary.chunk_indexes)


def _measure(kind: str, path: Path) -> dict[str, int] | str:
    done = subprocess.run(
        [sys.executable, "-c", _CHILD, kind, str(path)],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["failed"])[-1]
        return last[:60]
    result: dict[str, int] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size-mb", type=int, default=2048, help="bag size (default 2048)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="pyconnect-bag-memory-") as temporary:
        root = Path(temporary)
        print(f"writing {args.size_mb} MB of images (MCAP, cut MCAP, db3) in {root} ...")
        mcap_dir, cut, db3_dir, largest_message = write_bags(root, args.size_mb)
        chunk = _largest_chunk(mcap_dir / "images_0.mcap")
        bound = 2 * chunk + largest_message
        print(
            f"largest chunk {chunk / 2**20:.1f} MiB, largest message "
            f"{largest_message / 2**20:.2f} MiB: bound 2 x chunk + message = "
            f"{bound / 2**20:.1f} MiB over the RSS before reading\n"
        )
        cases = [
            ("MCAP", mcap_dir, ("pyconnect", "pyconnect-raw", "rosbags", "mcap-ros2")),
            ("MCAP cut short", cut, ("pyconnect", "pyconnect-raw", "rosbags", "mcap-ros2")),
            ("db3", db3_dir, ("pyconnect", "pyconnect-raw", "rosbags")),
        ]
        print(f"| {'bag':<15}| {'reader':<14}| messages | peak - base MiB | within bound |")
        print(f"|{'-' * 16}|{'-' * 15}|----------|-----------------|--------------|")
        for label, path, readers in cases:
            for kind in readers:
                result = _measure(kind, path)
                if isinstance(result, str):
                    print(f"| {label:<15}| {kind:<14}| failed: {result}")
                    continue
                grown = result["peak"] - result["base"]
                verdict = "yes" if grown <= bound else "no"
                print(
                    f"| {label:<15}| {kind:<14}| {result['count']:>8} | "
                    f"{grown / 2**20:>15.1f} | {verdict:>12} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
