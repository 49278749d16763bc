"""Large messages between two processes: ``python -m bench.large_messages [--quick]``.

Rows: one-way latency (p50, from the header stamp; same host clock) and delivered share of
isolated frames sent every 50 ms, then the rate of a sender publishing as fast as it can, for
1080p rgb8 images and a 10 MB PointCloud2, with pyconnect's large-message settings and with
stock Fast DDS (``PYCONNECT_LARGE_MESSAGES=0``); and reliable against best-effort subscribers at
320x240 ... 4K (what chose the sensor QoS default). Sender and receiver are pyconnect agents in
child processes; the receiver's ``decode_func`` keeps the message (no conversion measured here).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
from typing import Any

os.environ.setdefault("ROS_DOMAIN_ID", "48")
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

SIZES = {
    "320x240": (240, 320),
    "640x480": (480, 640),
    "1080p": (1080, 1920),
    "4K": (2160, 3840),
}
CLOUD_POINTS = 10 * 1024 * 1024 // 16  # x, y, z, rgb float32: 10 MiB


def _make_value(kind: str) -> Any:
    import numpy as np

    if kind == "cloud":
        dtype = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<f4")])
        return np.zeros(CLOUD_POINTS, dtype)
    height, width = SIZES[kind]
    return np.zeros((height, width, 3), np.uint8)


def _interface(kind: str) -> Any:
    from sensor_msgs.msg import Image, PointCloud2

    return PointCloud2 if kind == "cloud" else Image


def receiver(kind: str, qos: str, frames: int, timeout: float) -> None:
    """Print ``RESULT <received> <p50 ms> <rate fps>`` after ``frames`` or ``timeout``."""
    import threading

    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from pyconnect.ros.custom_node import CustomNode

    node = CustomNode("bench_large_rx", args=[], handle_signals=False)
    latencies: list[float] = []
    arrivals: list[float] = []
    done = threading.Event()

    def on_msg(msg: Any) -> Any:
        now = time.time_ns()
        stamp = msg.header.stamp
        latencies.append((now - (stamp.sec * 1_000_000_000 + stamp.nanosec)) / 1e6)
        arrivals.append(time.perf_counter())
        if len(latencies) >= frames:
            done.set()
        return None

    reliability = ReliabilityPolicy.RELIABLE if qos == "reliable" else ReliabilityPolicy.BEST_EFFORT
    node.add_agent(
        conn_name="bench_large",
        conn_type="sub",
        data_interface=_interface(kind),
        decode_func=on_msg,
        qos=QoSProfile(depth=5, reliability=reliability),
    )
    node.spin(run_thread=True)
    print("READY", flush=True)
    done.wait(timeout)
    rate = (len(arrivals) - 1) / (arrivals[-1] - arrivals[0]) if len(arrivals) > 2 else 0.0
    p50 = statistics.median(latencies) if latencies else float("nan")
    print(f"RESULT {len(latencies)} {p50:.3f} {rate:.1f}", flush=True)
    os._exit(0)


def sender(kind: str, frames: int, period: float) -> None:
    """Publish ``frames`` values (fresh stamp each) every ``period`` s (0: as fast as possible)."""
    from pyconnect.ros.custom_node import CustomNode

    node = CustomNode("bench_large_tx", args=[], handle_signals=False)
    pub = node.add_agent(
        conn_name="bench_large", conn_type="pub", data_interface=_interface(kind), qos=5
    )
    node.spin(run_thread=True)
    value = _make_value(kind)
    deadline = time.monotonic() + 30
    while pub.subscriber_count == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)  # the reader's side of discovery
    print("READY", flush=True)
    for _ in range(frames):
        started = time.perf_counter()
        pub.send(value)
        if period:
            time.sleep(max(0.0, period - (time.perf_counter() - started)))
    time.sleep(1.0)
    os._exit(0)


def run_case(
    kind: str, qos: str, *, tuned: bool, frames: int, period: float
) -> tuple[int, float, float]:
    """(received, p50 ms, receive rate) of one sender/receiver pair."""
    env = dict(os.environ)
    env["PYCONNECT_LARGE_MESSAGES"] = "1" if tuned else "0"  # as `pyconnect run` does
    if not tuned:
        for name in (
            "MALLOC_MMAP_THRESHOLD_",
            "MALLOC_TRIM_THRESHOLD_",
            "FASTRTPS_DEFAULT_PROFILES_FILE",
        ):
            env.pop(name, None)
    timeout = 20.0 + frames * max(period, 0.05)
    rx = subprocess.Popen(
        [sys.executable, "-m", "bench.large_messages", "--rx", kind, qos, str(frames), str(timeout)],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env,
    )  # fmt: skip
    assert rx.stdout is not None
    rx.stdout.readline()
    tx = subprocess.Popen(
        [sys.executable, "-m", "bench.large_messages", "--tx", kind, str(frames), str(period)],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
    )  # fmt: skip
    try:
        out, _ = rx.communicate(timeout=timeout + 30)
    except subprocess.TimeoutExpired:
        rx.kill()
        out, _ = rx.communicate()
    tx.wait(60)
    for line in out.splitlines():
        if line.startswith("RESULT "):
            _, count, p50, rate = line.split()
            return int(count), float(p50), float(rate)
    return 0, float("nan"), 0.0


def main(quick: bool | None = None) -> None:
    if quick is None:
        quick = "--quick" in sys.argv or os.environ.get("PYCONNECT_BENCH_QUICK") == "1"
    frames = 20 if quick else 60
    started = time.perf_counter()
    print(f"{'case':46} {'delivered':>9} {'p50 ms':>8} {'fps':>7}  target")
    for kind, target in (("1080p", "<= 5 ms, >= 100 fps"), ("cloud", "<= 5 ms (10 MB)")):
        for tuned in (True, False):
            label = "pyconnect settings" if tuned else "stock Fast DDS"
            count, p50, _ = run_case(kind, "reliable", tuned=tuned, frames=frames, period=0.05)
            _, _, rate = run_case(kind, "reliable", tuned=tuned, frames=frames * 3, period=0.0)
            print(
                f"{kind + ' reliable, ' + label:46} {count:>4}/{frames:<4} {p50:8.2f} {rate:7.1f}"
                f"  {target if tuned else ''}"
            )
    for kind in SIZES:
        for qos in ("reliable", "best_effort"):
            for tuned in (True, False):
                if quick and kind != "1080p" and not tuned:
                    continue
                label = "pyconnect settings" if tuned else "stock Fast DDS"
                count, p50, _ = run_case(kind, qos, tuned=tuned, frames=frames, period=0.05)
                print(f"{kind + ' ' + qos + ', ' + label:46} {count:>4}/{frames:<4} {p50:8.2f}")
    print(
        f"({time.perf_counter() - started:.0f} s; isolated frames every 50 ms; fps: the sender "
        "publishes back to back; latency from the header stamp, same host clock)"
    )


if __name__ == "__main__":
    if len(sys.argv) == 6 and sys.argv[1] == "--rx":
        receiver(sys.argv[2], sys.argv[3], int(sys.argv[4]), float(sys.argv[5]))
    elif len(sys.argv) == 5 and sys.argv[1] == "--tx":
        sender(sys.argv[2], int(sys.argv[3]), float(sys.argv[4]))
    else:
        main()
