"""Which reliability a sensor subscriber needs: ``python -m bench.sensor_qos [--quick]``.

What chose the sensor QoS default (pyconnect.ros.qos): rgb8 Images from 320x240 to 4K between
two processes on stock Fast DDS (no ``PYCONNECT_LARGE_MESSAGES``, no profile file, no malloc
settings: what a user gets without ``pyconnect run``), isolated frames sent every 50 ms by a
pyconnect ``pub`` agent with its default QoS (reliable). For each size, three receivers, each
in its own process and run: a best-effort sub, a reliable sub, and a sub with the default sensor
QoS (it follows the publishers: reliable here). Rows: frames delivered out of those sent and
the p50 one-way latency, value in -> value out (the sender writes ``time.time_ns()`` into the
first 8 bytes of the array just before ``send()``; same host clock).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import threading
import time
from typing import Any

os.environ.setdefault("ROS_DOMAIN_ID", "49")
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

from bench.large_messages import SIZES, _make_value, _shut_down, _stamp_bytes

MODES = ("best_effort", "reliable", "default")
TOPIC = "bench_sensor_qos"
PERIOD = 0.05


def stock_environment() -> dict[str, str]:
    """This environment without anything that tunes Fast DDS or glibc for large messages."""
    env = dict(os.environ)
    for name in (
        "FASTRTPS_DEFAULT_PROFILES_FILE",
        "MALLOC_MMAP_THRESHOLD_",
        "MALLOC_TRIM_THRESHOLD_",
    ):
        env.pop(name, None)
    env["PYCONNECT_LARGE_MESSAGES"] = "0"
    return env


def receiver(mode: str) -> None:
    """Print ``RESULT <received> <p50 ms> <reliability>`` once stdin has a line (or closes)."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import Image

    from pyconnect.ros.custom_node import CustomNode

    qos: Any = None
    if mode != "default":
        reliable = mode == "reliable"
        policy = ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT
        qos = QoSProfile(depth=5, reliability=policy)
    node = CustomNode("bench_sensor_qos_rx", args=[], handle_signals=False)
    latencies: list[float] = []
    lock = threading.Lock()

    def on_value(value: Any) -> None:
        now = time.time_ns()
        with lock:
            latencies.append((now - int(_stamp_bytes(value)[0])) / 1e6)

    sub = node.add_agent(
        conn_name=TOPIC, conn_type="sub", data_interface=Image, response_func=on_value, qos=qos
    )
    node.spin(run_thread=True)
    print("READY", flush=True)
    sys.stdin.readline()
    with lock:
        p50 = statistics.median(latencies) if latencies else float("nan")
        count = len(latencies)
    reliability = sub.subscription.qos_profile.reliability.name.lower()
    print(f"RESULT {count} {p50:.3f} {reliability}", flush=True)
    _shut_down(node)


def sender(kind: str, frames: int) -> None:
    """Publish ``frames`` values every ``PERIOD`` s once a reader matched, then end."""
    from sensor_msgs.msg import Image

    from pyconnect.ros.custom_node import CustomNode

    value = _make_value(kind)
    stamp = _stamp_bytes(value)
    node = CustomNode("bench_sensor_qos_tx", args=[], handle_signals=False)
    pub = node.add_agent(conn_name=TOPIC, conn_type="pub", data_interface=Image)
    node.spin(run_thread=True)
    deadline = time.monotonic() + 30
    while pub.subscriber_count == 0 and time.monotonic() < deadline:
        time.sleep(0.02)
    time.sleep(0.3)  # the reader's side of discovery
    for _ in range(frames):
        started = time.perf_counter()
        stamp[0] = time.time_ns()
        pub.send(value)
        time.sleep(max(0.0, PERIOD - (time.perf_counter() - started)))
    from rclpy.duration import Duration

    # A reliable reader acknowledges (its repairs included); a best-effort one never holds it up.
    pub.publisher.wait_for_all_acked(Duration(seconds=3))
    _shut_down(node)


def run_case(kind: str, mode: str, frames: int) -> tuple[int, float, str]:
    """(frames delivered, p50 ms, the receiver's reliability) of one sender/receiver pair."""
    env = stock_environment()
    here = [sys.executable, "-m", "bench.sensor_qos"]
    rx = subprocess.Popen(
        [*here, "--rx", mode], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL, text=True, env=env,
    )  # fmt: skip
    assert rx.stdin is not None and rx.stdout is not None
    rx.stdout.readline()
    tx = subprocess.Popen(
        [*here, "--tx", kind, str(frames)], stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL, env=env,
    )  # fmt: skip
    try:
        tx.wait(60 + frames * PERIOD)
    except subprocess.TimeoutExpired:
        tx.kill()
        tx.wait()
    try:
        out, _ = rx.communicate("stop\n", timeout=30)
    except subprocess.TimeoutExpired:
        rx.kill()
        out, _ = rx.communicate()
    for line in out.splitlines():
        if line.startswith("RESULT "):
            _, count, p50, reliability = line.split()
            return int(count), float(p50), reliability
    return 0, float("nan"), "?"


def main(quick: bool | None = None) -> None:
    if quick is None:
        quick = "--quick" in sys.argv or os.environ.get("PYCONNECT_BENCH_QUICK") == "1"
    frames = 10 if quick else 20
    started = time.perf_counter()
    print(
        f"\nsensor QoS on stock Fast DDS: rgb8 Image, {frames} frames every "
        f"{PERIOD * 1000:.0f} ms from a default (reliable) pub agent, two processes"
    )
    print(f"{'size':8} {'subscriber':28} {'delivered':>9} {'p50 ms':>8}")
    for kind in SIZES:
        for mode in MODES:
            count, p50, reliability = run_case(kind, mode, frames)
            label = f"default (chose {reliability})" if mode == "default" else mode
            print(f"{kind:8} {label:28} {count:>4}/{frames:<4} {p50:8.2f}", flush=True)
    print(f"({time.perf_counter() - started:.0f} s)")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--rx":
        receiver(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == "--tx":
        sender(sys.argv[2], int(sys.argv[3]))
    else:
        main()
