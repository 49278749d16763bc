"""Tables at scale: Parquet export, Dask workers, and the cost of ``topic hz`` on a 1 kHz topic.

1. Parquet export of the robot_localization bags: ``export_parquet`` (ours) against
   rosbags-dataframe's ``get_dataframe`` + ``DataFrame.to_parquet`` with the same columns.
2. Every topic of the shared robot_localization and rosbags_rs bags read with ``read_bags`` on a
   local dask.distributed cluster of 1 and then 2 single-threaded worker processes.
3. ``pyconnect topic hz`` against a bare rclpy raw subscriber on a 1 kHz topic: CPU seconds per
   wall second of each process (getrusage of the child), same publisher, same run.

Run: ``python -m bench.tables``. Numbers from a loaded machine are indicative only.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BAGS = (Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "bags").resolve()
LOCALIZATION = [
    BAGS / "robot_localization_converted" / "test1_ros2_mcap_zstd",
    BAGS / "robot_localization_converted" / "test2_ros2_mcap_zstd",
]
DASK_BAGS = [
    *LOCALIZATION,
    BAGS / "rosbags_rs" / "test_bag_mcap",
    BAGS / "evo" / "nav2_turtlebot.mcap",
]
DASK_COPIES = 3  # enough reading per worker that scheduling is not what is measured
ROUNDS = 3
HZ_SECONDS = 8.0


def best(run: object) -> float:
    times = []
    for _ in range(ROUNDS):
        started = time.perf_counter()
        run()  # type: ignore[operator]
        times.append(time.perf_counter() - started)
    return min(times)


# -- 1. Parquet export --------------------------------------------------------------------------
def export_ours(target: Path) -> None:
    from pyconnect.record.parquet_export import export_parquet

    for bag in LOCALIZATION:
        export_parquet(bag, target / bag.name, force=True)  # each round overwrites the last


def export_rosbags_dataframe(target: Path, keys: dict[str, list[str]]) -> None:
    from rosbags.dataframe import get_dataframe
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_JAZZY)
    for bag in LOCALIZATION:
        (target / bag.name).mkdir(parents=True, exist_ok=True)
        with AnyReader([bag], default_typestore=typestore) as reader:
            for connection in reader.connections:
                frame = get_dataframe(reader, connection.topic, keys[connection.topic])
                name = connection.topic.strip("/").replace("/", "__")
                frame.to_parquet(target / bag.name / f"{name}.parquet")


def column_keys() -> dict[str, list[str]]:
    """Our flattened column names (less log_time_ns): the keys rosbags-dataframe is given."""
    from pyconnect.record.bag_reader import open_bag

    keys: dict[str, list[str]] = {}
    for bag in LOCALIZATION:
        with open_bag(bag) as reader:
            for topic in reader.topics:
                keys[topic] = reader.to_arrow(topic).schema.names[1:]
    return keys


def bench_parquet() -> None:
    keys = column_keys()
    with tempfile.TemporaryDirectory() as folder:
        ours = best(lambda: export_ours(Path(folder) / "ours"))
        theirs = best(lambda: export_rosbags_dataframe(Path(folder) / "theirs", keys))
    print("\nParquet export of the robot_localization bags (best of 3)")
    print(f"{'exporter':<46}{'seconds':>10}{'ratio':>8}")
    print(f"{'pyconnect export_parquet':<46}{ours:>10.3f}{1.0:>8.2f}")
    print(
        f"{'rosbags-dataframe get_dataframe + to_parquet':<46}{theirs:>10.3f}{theirs / ours:>8.2f}"
    )


# -- 2. Dask workers ---------------------------------------------------------------------------
def read_everything_with(workers: int) -> float:
    """Seconds to read every topic of the Dask bags, each bag read ``DASK_COPIES`` times.

    The rows are counted on the workers, so the time is the reading (what scales with
    workers), not the transfer of every table to this process.
    """
    import dask
    from distributed import Client, LocalCluster

    from pyconnect.record import bag_info
    from pyconnect.record.dask import read_bags

    frames = [
        read_bags([bag] * DASK_COPIES, topic=topic.name)
        for bag in DASK_BAGS
        for topic in bag_info(bag).topics
        if topic.message_count
    ]
    row_counts = [frame.map_partitions(len).sum() for frame in frames]
    with (
        LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        Client(cluster),
    ):
        dask.compute(*row_counts)  # warm up: each worker compiles its codecs once
        started = time.perf_counter()
        dask.compute(*row_counts)
        return time.perf_counter() - started


def bench_dask() -> None:
    one = read_everything_with(1)
    two = read_everything_with(2)
    print(
        f"\nread_bags: every topic of {len(DASK_BAGS)} shared bags, each {DASK_COPIES} times, "
        "on a local cluster (rows counted on the workers; after a warm-up run)"
    )
    print(f"{'workers':<46}{'seconds':>10}{'speed-up':>10}")
    print(f"{'1 worker process':<46}{one:>10.3f}{1.0:>10.2f}")
    print(f"{'2 worker processes':<46}{two:>10.3f}{one / two:>10.2f}")


# -- 3. topic hz on 1 kHz ------------------------------------------------------------------------
PUBLISHER = """
import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import String
rclpy.init()
node = Node("bench_1khz")
pub = node.create_publisher(String, "fast", 10)
message = String(data="x" * 32)
def tick():
    try:
        pub.publish(message)
    except RCLError:  # SIGINT shut the context down while a tick was due: the run is over
        pass
node.create_timer(0.001, tick)
print("READY", flush=True)
try:
    rclpy.spin(node)
# SIGINT before or after rclpy's handler; or it shut the context down while the executor was
# making its next wait set (rcl: "the given context is not valid")
except (KeyboardInterrupt, ExternalShutdownException, RCLError):
    pass
"""

BARE_SUBSCRIBER = """
import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from std_msgs.msg import String
rclpy.init()
node = Node("bench_bare")
count = [0]
def on_message(data):
    count[0] += 1
node.create_subscription(String, "fast", on_message, qos_profile_sensor_data, raw=True)
try:
    rclpy.spin(node)
except (KeyboardInterrupt, ExternalShutdownException, RCLError):  # SIGINT, as the publisher's
    print(count[0], flush=True)
"""


def cpu_of(argv: list[str]) -> tuple[float, str]:
    """CPU seconds per wall second of a process run for HZ_SECONDS, and its last line."""
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    started = time.monotonic()
    time.sleep(HZ_SECONDS)
    process.send_signal(signal.SIGINT)
    _pid, _status, usage = os.wait4(process.pid, 0)
    wall = time.monotonic() - started
    assert process.stdout is not None
    lines = process.stdout.read().strip().splitlines()
    process.stdout.close()
    process.returncode = 0
    return (usage.ru_utime + usage.ru_stime) / wall, lines[-2] if len(lines) > 1 else ""


def bench_hz() -> None:
    publisher = subprocess.Popen(
        [sys.executable, "-c", PUBLISHER], stdout=subprocess.PIPE, text=True
    )
    try:
        assert publisher.stdout is not None
        publisher.stdout.readline()
        bare, _ = cpu_of([sys.executable, "-c", BARE_SUBSCRIBER])
        hz, rate = cpu_of([sys.executable, "-m", "pyconnect.cli", "topic", "hz", "/fast"])
    finally:
        publisher.send_signal(signal.SIGINT)
        publisher.communicate(timeout=30)
    print(f"\ntopic hz on a 1 kHz topic ({HZ_SECONDS:.0f} s each; hz printed: {rate.strip()})")
    print(f"{'subscriber':<46}{'CPU s/s':>10}{'ratio':>8}")
    print(f"{'bare rclpy raw subscription (no work)':<46}{bare:>10.3f}{1.0:>8.2f}")
    print(f"{'pyconnect topic hz':<46}{hz:>10.3f}{hz / bare:>8.2f}")


def main() -> None:
    bench_parquet()
    bench_dask()
    bench_hz()


if __name__ == "__main__":
    main()
