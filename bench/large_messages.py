"""Large messages between two processes: ``python -m bench.large_messages [--quick]``.

Rows: one-way latency (p50) and delivered share of isolated frames sent every 50 ms, then the
rate of a sender publishing as fast as it can, for 1080p rgb8 images and a 10 MB PointCloud2,
with pyconnect's large-message settings (the environment ``pyconnect run`` gives) and with
stock Fast DDS; and reliable against best-effort subscribers at 320x240 ... 4K (what chose the
sensor QoS default). Sender and receiver are pyconnect agents in child processes on their
default (raw CDR) path, value in to value out: the sender writes ``time.time_ns()`` into the
first 8 bytes of the array just before ``send()``, the receiver's ``response_func`` reads them
from the decoded array (same host clock), so encode, DDS, take and decode are all inside.

Beside them, raw rclpy with the same settings (an Image built with ``frombytes``, a
SingleThreadedExecutor subscriber), split into stages by Fast DDS's message info: publish (stamp
-> source timestamp: rclpy's conversion and Fast DDS's serialisation), delivery (source ->
reception timestamp: the shared-memory transport, 64 KB DATA_FRAG fragments), take (reception ->
callback: executor wake-up, rmw take, rclpy's message). Then the Python-side conversion of
pyconnect's raw path in this process: CDR bytes -> ndarray and ndarray -> CDR bytes.
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


def _stamp_bytes(value: Any) -> Any:
    """The first 8 bytes of an array's data, where the sender writes its clock."""
    import numpy as np

    return value.reshape(-1).view(np.uint8)[:8].view(np.int64)


class _Arrivals:
    """One-way latencies and arrival times of a receiver; ``done`` after ``frames``."""

    def __init__(self, frames: int) -> None:
        import threading

        self.frames = frames
        self.latencies: list[float] = []
        self.arrivals: list[float] = []
        self.stages: list[tuple[int, int, int]] = []
        self.done = threading.Event()

    def add(self, sent_ns: int, now_ns: int) -> None:
        self.latencies.append((now_ns - sent_ns) / 1e6)
        self.arrivals.append(time.perf_counter())
        if len(self.latencies) >= self.frames:
            self.done.set()

    def result(self) -> str:
        arrivals = self.arrivals
        rate = (len(arrivals) - 1) / (arrivals[-1] - arrivals[0]) if len(arrivals) > 2 else 0.0
        p50 = statistics.median(self.latencies) if self.latencies else float("nan")
        stages = " ".join(
            f"{statistics.median(column) / 1e6:.3f}" for column in zip(*self.stages, strict=True)
        )
        return f"RESULT {len(self.latencies)} {p50:.3f} {rate:.1f} {stages}".strip()


def receiver(impl: str, kind: str, qos: str, frames: int, timeout: float) -> None:
    """Print ``RESULT <received> <p50 ms> <rate fps> [stage ms...]`` after ``frames``."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    reliability = ReliabilityPolicy.RELIABLE if qos == "reliable" else ReliabilityPolicy.BEST_EFFORT
    profile = QoSProfile(depth=5, reliability=reliability)
    got = _Arrivals(frames)
    if impl == "rclpy":
        import threading

        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        rclpy.init()
        node = rclpy.create_node("bench_large_rx")

        def on_msg(msg: Any, info: Any) -> None:
            now = time.time_ns()
            stamp = msg.header.stamp
            sent = stamp.sec * 1_000_000_000 + stamp.nanosec
            source, received = info["source_timestamp"], info["received_timestamp"]
            got.stages.append((source - sent, received - source, now - received))
            got.add(sent, now)

        node.create_subscription(_interface(kind), "bench_large", on_msg, profile)
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        node.bench_spin_thread = threading.Thread(target=executor.spin, daemon=True)
        node.bench_spin_thread.start()
    else:
        from pyconnect.ros.custom_node import CustomNode

        node = CustomNode("bench_large_rx", args=[], handle_signals=False)

        def on_value(value: Any) -> None:
            now = time.time_ns()
            got.add(int(_stamp_bytes(value)[0]), now)

        node.add_agent(
            conn_name="bench_large",
            conn_type="sub",
            data_interface=_interface(kind),
            response_func=on_value,
            qos=profile,
        )
        node.spin(run_thread=True)
    print("READY", flush=True)
    got.done.wait(timeout)
    print(got.result(), flush=True)
    _shut_down(node)


def sender(impl: str, kind: str, frames: int, period: float) -> None:
    """Publish ``frames`` values (fresh clock each) every ``period`` s (0: as fast as possible)."""
    value = _make_value(kind)
    stamp = _stamp_bytes(value)
    if impl == "rclpy":
        import rclpy

        rclpy.init()
        node = rclpy.create_node("bench_large_tx")
        publisher = node.create_publisher(_interface(kind), "bench_large", 5)

        def send() -> None:  # the usual raw rclpy way, as fast as rclpy allows
            now = time.time_ns()
            msg = _rclpy_message(kind, value)
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now, 1_000_000_000)
            publisher.publish(msg)

        def readers() -> int:
            count: int = publisher.get_subscription_count()
            return count
    else:
        from pyconnect.ros.custom_node import CustomNode

        pyc = CustomNode("bench_large_tx", args=[], handle_signals=False)
        node = pyc
        pub = pyc.add_agent(
            conn_name="bench_large", conn_type="pub", data_interface=_interface(kind), qos=5
        )
        pyc.spin(run_thread=True)

        def send() -> None:
            stamp[0] = time.time_ns()
            pub.send(value)

        def readers() -> int:
            count: int = pub.subscriber_count
            return count

    deadline = time.monotonic() + 30
    while readers() == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)  # the reader's side of discovery
    print("READY", flush=True)
    for _ in range(frames):
        started = time.perf_counter()
        send()
        if period:
            time.sleep(max(0.0, period - (time.perf_counter() - started)))
    time.sleep(1.0)
    _shut_down(node)


def _rclpy_message(kind: str, value: Any) -> Any:
    """The message raw rclpy code builds for ``value`` (data filled with ``frombytes``)."""
    from sensor_msgs.msg import Image, PointCloud2, PointField

    if kind == "cloud":
        names = value.dtype.names
        msg = PointCloud2(
            height=1, width=len(value), point_step=value.dtype.itemsize,
            row_step=value.nbytes, is_dense=True,
            fields=[PointField(name=name, offset=4 * index, datatype=PointField.FLOAT32, count=1)
                    for index, name in enumerate(names)],
        )  # fmt: skip
    else:
        height, width = value.shape[:2]
        msg = Image(height=height, width=width, encoding="rgb8", step=width * 3)
    msg.data.frombytes(value.reshape(-1).view("u1").data)
    return msg


def _shut_down(node: Any) -> None:
    """End the process with its DDS participant destroyed: Fast DDS then removes its shared-
    memory segment, which ``os._exit`` alone would leave in ``/dev/shm`` (64 MiB each)."""
    try:
        if hasattr(node, "shutdown"):
            node.shutdown()
        else:  # raw rclpy: the participant goes with the context's handle, not at shutdown
            context = node.context
            context.try_shutdown()  # ends the spin thread's loop
            spinner = getattr(node, "bench_spin_thread", None)
            if spinner is not None:
                spinner.join(5)
            node.destroy_node()
            context.destroy()
    finally:
        sys.stdout.flush()
        os._exit(0)


def case_environment(*, tuned: bool) -> dict[str, str]:
    """The environment ``pyconnect run`` gives (tuned), or stock Fast DDS and glibc."""
    from pyconnect.ros.large_messages import configure_environment

    env = dict(os.environ)
    for name in ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_"):
        env.pop(name, None)
    env.pop("FASTRTPS_DEFAULT_PROFILES_FILE", None)
    env["PYCONNECT_LARGE_MESSAGES"] = "1" if tuned else "0"
    if tuned:
        reason = configure_environment(env, default_on=True)
        if reason is not None:
            raise SystemExit(f"large-message settings not applicable here: {reason}")
    return env


def run_case(
    kind: str, qos: str, *, tuned: bool, frames: int, period: float, impl: str = "pyconnect"
) -> tuple[int, float, float, list[float]]:
    """(received, p50 ms, receive rate, stage ms) of one sender/receiver pair."""
    env = case_environment(tuned=tuned)
    timeout = 20.0 + frames * max(period, 0.05)
    rx = subprocess.Popen(
        [sys.executable, "-m", "bench.large_messages", "--rx", impl, kind, qos, str(frames),
         str(timeout)],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env,
    )  # fmt: skip
    assert rx.stdout is not None
    rx.stdout.readline()
    tx = subprocess.Popen(
        [sys.executable, "-m", "bench.large_messages", "--tx", impl, kind, str(frames),
         str(period)],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
    )  # fmt: skip
    try:
        out, _ = rx.communicate(timeout=timeout + 30)
    except subprocess.TimeoutExpired:
        rx.kill()
        out, _ = rx.communicate()
    try:
        tx.wait(60)
    except subprocess.TimeoutExpired:
        tx.kill()
        tx.wait()
    for line in out.splitlines():
        if line.startswith("RESULT "):
            _, count, p50, rate, *stages = line.split()
            return int(count), float(p50), float(rate), [float(x) for x in stages]
    return 0, float("nan"), 0.0, []


def python_side_conversion() -> None:
    """pyconnect's raw path in this process: CDR bytes -> ndarray, ndarray -> CDR bytes."""
    for kind, msg_type in (
        ("1080p", "sensor_msgs/msg/Image"),
        ("cloud", "sensor_msgs/msg/PointCloud2"),
    ):
        _conversion_table(kind, msg_type)


def _conversion_table(kind: str, msg_type: str) -> None:
    import numpy as np

    from bench.timing import compare
    from pyconnect.codecs import default_registry
    from pyconnect.ros.raw_path import RawDecoder, RawEncoder

    value = _make_value(kind)
    rng = np.random.default_rng(3)
    if kind == "cloud":
        for axis in ("x", "y", "z"):
            value[axis] = rng.random(len(value), np.float32)
    else:
        value[...] = rng.integers(0, 256, value.shape, dtype=np.uint8)
    decoder = RawDecoder(msg_type=msg_type, registry=default_registry)
    encoder = RawEncoder(
        msg_type=msg_type, registry=default_registry, has_header=True, describe="bench"
    )
    cdr, _ = encoder.encode(value, now=lambda: (1, 2), frame_id="camera")
    compare(
        f"Python-side conversion of the raw path, {kind} ({value.nbytes / 1e6:.1f} MB)",
        [
            ("one memcpy into a fresh buffer: bytes(arr)", lambda: bytes(value)),
            ("take -> value: RawDecoder.decode (writable, in place)", lambda: decoder.decode(cdr)),
            (
                "value -> publish: RawEncoder.encode",
                lambda: encoder.encode(value, now=lambda: (1, 2), frame_id="camera"),
            ),
        ],
        budget_s=0.2,
    )


def main(quick: bool | None = None) -> None:
    from pyconnect.ros.large_messages import MALLOC_SETTINGS

    if quick is None:
        quick = "--quick" in sys.argv or os.environ.get("PYCONNECT_BENCH_QUICK") == "1"
    if not all(os.environ.get(name) == value for name, value in MALLOC_SETTINGS.items()):
        # The conversion tables run under the settings from the start, as `pyconnect run`.
        sys.stdout.flush()
        subprocess.run(
            [sys.executable, "-m", "bench.large_messages", "--conversion"],
            env={**os.environ, **MALLOC_SETTINGS},
            check=True,
        )
    else:
        python_side_conversion()
    frames = 20 if quick else 60
    started = time.perf_counter()
    print(f"\n{'case':50} {'delivered':>9} {'p50 ms':>8} {'fps':>7}  target")
    for kind, target in (("1080p", "<= 5 ms, >= 100 fps"), ("cloud", "<= 5 ms (10 MB)")):
        for impl, tuned, label in (
            ("pyconnect", True, "pyconnect settings"),
            ("rclpy", True, "raw rclpy, same settings"),
            ("pyconnect", False, "stock Fast DDS"),
        ):
            count, p50, _, _ = run_case(
                kind, "reliable", tuned=tuned, frames=frames, period=0.05, impl=impl
            )
            _, _, rate, _ = run_case(
                kind, "reliable", tuned=tuned, frames=frames * 3, period=0.0, impl=impl
            )
            print(
                f"{kind + ' reliable, ' + label:50} {count:>4}/{frames:<4} {p50:8.2f} {rate:7.1f}"
                f"  {target if impl == 'pyconnect' and tuned else ''}"
            )
    print("\nraw rclpy 1080p, same settings, stages (p50 ms): publish / delivery / take")
    for _ in range(1 if quick else 2):
        count, p50, _, stages = run_case(
            "1080p", "reliable", tuned=True, frames=frames, period=0.05, impl="rclpy"
        )
        print(f"  one-way {p50:.2f} = " + " / ".join(f"{stage:.2f}" for stage in stages))
    print(f"\n{'QoS sweep':50} {'delivered':>9} {'p50 ms':>8}")
    for kind in SIZES:
        for qos in ("reliable", "best_effort"):
            for tuned in (True, False):
                if quick and kind != "1080p" and not tuned:
                    continue
                label = "pyconnect settings" if tuned else "stock Fast DDS"
                count, p50, _, _ = run_case(kind, qos, tuned=tuned, frames=frames, period=0.05)
                print(f"{kind + ' ' + qos + ', ' + label:50} {count:>4}/{frames:<4} {p50:8.2f}")
    print(
        f"({time.perf_counter() - started:.0f} s; isolated frames every 50 ms; fps: the sender "
        "publishes back to back; latency value in -> value out, same host clock)"
    )


if __name__ == "__main__":
    if len(sys.argv) == 7 and sys.argv[1] == "--rx":
        receiver(sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5]), float(sys.argv[6]))
    elif len(sys.argv) == 6 and sys.argv[1] == "--tx":
        sender(sys.argv[2], sys.argv[3], int(sys.argv[4]), float(sys.argv[5]))
    elif sys.argv[1:] == ["--conversion"]:
        python_side_conversion()
    else:
        main()
