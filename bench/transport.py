"""Peers over zenoh against zenoh's own Python pub/sub and against CustomNodes over DDS.

``python -m bench.transport``. Two rows, each measured for pairs of processes on this
machine, side by side in one run, then the per-stage costs of a peer's send and receive
(``bench.transport_stages``):

- small messages (std_msgs/String) per second at the receiver while the sender publishes as
  fast as it can: raw zenoh ``put(bytes)`` -> callback counting (the floor), a pyconnect
  ``Peer`` pub -> sub decoding each String, two ``CustomNode``s over DDS; goal >= 0.8x raw.
  Two more pairs put a Peer on one side only (a Peer sender -> a raw receiver, a raw sender
  with rmw_zenoh's attachment -> a Peer receiver): the slower of the two sets the Peer pair's
  rate.
  Each row also shows what the receiving Peer counted as lost and the CPU each process spent
  per message (all its threads, zenoh's included): on a 2-core machine sender and receiver
  share the cores, so a costlier sender slows the receiver too.
- one-way latency of a 1080p bgr8 Image (6.2 MB), p50 and p90 over samples sent every 50 ms
  (sender stamps a sequence number into the pixels; both sides read ``time.time_ns``): raw
  zenoh bytes, Peer ndarray -> ndarray, CustomNode ndarray -> ndarray; goal <= 5 ms p50.

Receivers run in child processes (``--receive KIND ROW LOCATOR``); zenoh pairs meet on a
loopback port with multicast scouting off.
"""

from __future__ import annotations

import json
import os
import socket
import statistics
import struct
import subprocess
import sys
import time
from dataclasses import dataclass
from typing import Any

os.environ.setdefault("ROS_DOMAIN_ID", "48")
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

RATE_SECONDS = 3.0
LATENCY_SAMPLES = 40
LATENCY_PERIOD = 0.05
IDLE_END = 2.0
SHAPE = (1080, 1920, 3)
KINDS = ("raw zenoh", "pyconnect Peer", "CustomNode DDS")
# The rate row also shows a peer subscription keeping 1000 samples instead of ROS's 10, and
# each side of a Peer against the raw other side, to show which side sets the rate.
PEER_TO_RAW = "Peer -> raw"
RAW_TO_PEER = "raw -> Peer"
RATE_KINDS = (
    "raw zenoh",
    "pyconnect Peer",
    "Peer depth=1000",
    PEER_TO_RAW,
    RAW_TO_PEER,
    "CustomNode DDS",
)
RATE_ROWS = {
    "raw zenoh": "put(bytes) -> Python callback counting (zenoh's FIFO: the receiver never "
    "drops, a full queue stalls the link and the sender's congestion control drops)",
    "pyconnect Peer": "send(str) -> rmw_zenoh attachment -> keep-last 10 (+ burst allowance "
    "while the agent keeps up) -> agent thread: sequence check, decode, response_func; when the "
    "receiver falls behind, keep-last skips (counted in lost*)",
    "Peer depth=1000": "the same with keep-last 1000",
    PEER_TO_RAW: "a Peer's send(str) -> a raw callback counting on the Peer's rmw_zenoh key",
    RAW_TO_PEER: "raw put(bytes) with rmw_zenoh's attachment on the rmw_zenoh key -> a Peer sub",
    "CustomNode DDS": "two CustomNodes over Fast DDS, keep-last 10",
}


@dataclass(frozen=True)
class RateRow:
    """One pair's small-message run: what the receiver handled, what the sender put."""

    rate: float  # messages handled per second at the receiver, first to last
    received: int
    sent: int  # send()/put() calls that returned
    lost: int | None  # what the receiving Peer counted as lost (sequence gaps); None: no count
    receiver_us: float  # receiver process CPU (all threads) per message handled
    sender_us: float  # sender process CPU (all threads) per message sent


def _zenoh_config(locator: str, *, listen: bool) -> Any:
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints" if listen else "connect/endpoints", f'["{locator}"]')
    return config


def _seq_of(pixels: Any) -> int:
    seq: int = struct.unpack("<q", pixels[0, :8, 0].tobytes())[0]
    return seq


# -- receivers (child processes) --------------------------------------------------------------
def receive(kind: str, row: str, locator: str) -> None:
    arrivals: list[tuple[int, int]] = []
    last = [time.monotonic()]

    def note(seq: int) -> None:
        arrivals.append((seq, time.time_ns()))
        last[0] = time.monotonic()

    closer, counted_lost = _start_receiver(kind, row, locator, note)
    print("READY", flush=True)
    cpu_start = _process_cpu()
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        time.sleep(0.2)
        if arrivals and time.monotonic() - last[0] > IDLE_END:
            break
    cpu = _process_cpu() - cpu_start
    lost = counted_lost()
    closer()
    if row == "latency":
        print(json.dumps(arrivals), flush=True)
        return
    span = arrivals[-1][1] - arrivals[0][1] if len(arrivals) > 1 else 0
    print(json.dumps([len(arrivals), span, cpu, lost]), flush=True)


def _process_cpu() -> float:
    """CPU seconds of this process, all threads (zenoh's included)."""
    times = os.times()
    return times.user + times.system


def _rmw_key(type_name: str) -> str:
    """The rmw_zenoh key a Peer's agent named ``bench`` uses for ``type_name``."""
    from pyconnect.transport import rmw_zenoh_keys as keys
    from pyconnect.transport.interface_types import message_interface
    from pyconnect.transport.peer import default_domain_id

    interface = message_interface(type_name)
    return keys.data_key(default_domain_id(), "bench", interface.type_name, interface.type_hash)


def _start_receiver(kind: str, row: str, locator: str, note: Any) -> Any:
    type_name = "sensor_msgs/msg/Image" if row == "latency" else "std_msgs/msg/String"
    if kind == PEER_TO_RAW:
        import zenoh

        session = zenoh.open(_zenoh_config(locator, listen=True))
        subscriber = session.declare_subscriber(_rmw_key(type_name), lambda _sample: note(0))
        return (lambda: (subscriber.undeclare(), session.close())), lambda: None
    if kind == "raw zenoh":
        import zenoh

        session = zenoh.open(_zenoh_config(locator, listen=True))
        if row == "latency":

            def on_sample(sample: zenoh.Sample) -> None:
                data = sample.payload.to_bytes()
                note(struct.unpack_from("<q", sample.attachment.to_bytes())[0])  # type: ignore[union-attr]
                del data
        else:

            def on_sample(sample: zenoh.Sample) -> None:
                note(0)

        subscriber = session.declare_subscriber("bench/raw", on_sample)
        return (lambda: (subscriber.undeclare(), session.close())), lambda: None
    if kind in ("pyconnect Peer", "Peer depth=1000", RAW_TO_PEER):
        from pyconnect.transport import Peer

        peer = Peer("bench_receiver", config=_zenoh_config(locator, listen=True))
        handler = (lambda value: note(_seq_of(value))) if row == "latency" else (lambda _v: note(0))
        agent = peer.add_agent(
            conn_name="bench",
            conn_type="sub",
            data_interface=type_name,
            response_func=handler,
            depth=1000 if kind == "Peer depth=1000" else 10,
        )
        return peer.shutdown, lambda: agent.dropped_count
    from pyconnect.ros.custom_node import CustomNode

    node = CustomNode("bench_receiver")
    handler = (lambda value: note(_seq_of(value))) if row == "latency" else (lambda _v: note(0))
    node.add_agent(
        conn_name="bench", conn_type="sub", data_interface=type_name, response_func=handler
    )
    node.spin(run_thread=True)
    return node.shutdown, lambda: None


# -- senders (this process) -------------------------------------------------------------------
class _Sender:
    def __init__(self, kind: str, row: str, locator: str) -> None:
        self.kind = kind
        type_name = "sensor_msgs/msg/Image" if row == "latency" else "std_msgs/msg/String"
        self._close: Any
        if kind == "raw zenoh":
            import zenoh

            self.session = zenoh.open(_zenoh_config(locator, listen=False))
            self.publisher = self.session.declare_publisher("bench/raw")
            self._close = lambda: (self.publisher.undeclare(), self.session.close())
        elif kind == RAW_TO_PEER:
            import zenoh

            self.session = zenoh.open(_zenoh_config(locator, listen=False))
            self.publisher = self.session.declare_publisher(
                _rmw_key(type_name), congestion_control=zenoh.CongestionControl.DROP
            )
            self._close = lambda: (self.publisher.undeclare(), self.session.close())
        elif kind in ("pyconnect Peer", "Peer depth=1000", PEER_TO_RAW):
            from pyconnect.transport import Peer

            peer = Peer("bench_sender", config=_zenoh_config(locator, listen=False))
            self.agent: Any = peer.add_agent(
                conn_name="bench", conn_type="pub", data_interface=type_name
            )
            self._close = peer.shutdown
        else:
            from rclpy.context import Context

            from pyconnect.ros.custom_node import CustomNode

            node = CustomNode("bench_sender", context=Context())  # a fresh one per pair
            self.agent = node.add_agent(
                conn_name="bench", conn_type="pub", data_interface=type_name
            )
            node.spin(run_thread=True)
            self._close = node.shutdown

    def connected(self) -> bool:
        if self.kind in ("raw zenoh", RAW_TO_PEER):
            status: Any = self.publisher.matching_status
            return bool(getattr(status, "matching", status))
        if self.kind == PEER_TO_RAW:  # a raw subscriber declares no liveliness token
            return bool(self.agent.matched)
        return bool(self.agent.subscriber_count > 0)

    def close(self) -> None:
        self._close()


def _run_pair(kind: str, row: str) -> Any:
    locator = f"tcp/127.0.0.1:{_free_port()}"
    child = subprocess.Popen(
        [sys.executable, "-m", "bench.transport", "--receive", kind, row, locator],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert child.stdout is not None
    if child.stdout.readline().strip() != "READY":
        child.kill()
        return None
    sender = _Sender(kind, row, locator)
    try:
        deadline = time.monotonic() + 30
        while not sender.connected():
            if time.monotonic() > deadline:
                return None
            time.sleep(0.05)
        time.sleep(0.5)  # let the last discovery messages settle before measuring
        cpu_start = _process_cpu()
        sent = _send_rate(sender) if row == "rate" else _send_latency(sender)
        sender_cpu = _process_cpu() - cpu_start
    finally:
        out = child.communicate(timeout=180)[0]
        sender.close()
    received = json.loads(out.strip().splitlines()[-1])
    if row == "rate":
        count, span_ns, receiver_cpu, lost = received
        return RateRow(
            rate=count / (span_ns / 1e9) if span_ns else 0.0,
            received=count,
            sent=sent,
            lost=lost,
            receiver_us=receiver_cpu / max(count, 1) * 1e6,
            sender_us=sender_cpu / max(sent, 1) * 1e6,
        )
    latencies = [(t - sent[seq]) / 1e6 for seq, t in received if seq in sent]
    return latencies


def _send_rate(sender: _Sender) -> int:
    from pyconnect.codecs import wire

    payload = wire.encode("hello", "std_msgs/msg/String")
    end = time.monotonic() + RATE_SECONDS
    sent = 0
    if sender.kind == "raw zenoh":
        put = sender.publisher.put
        while time.monotonic() < end:
            for _ in range(100):
                put(payload)
            sent += 100
        return sent
    if sender.kind == RAW_TO_PEER:
        from pyconnect.transport.rmw_zenoh_keys import ATTACHMENT

        put, pack, gid, clock = sender.publisher.put, ATTACHMENT.pack, bytes(16), time.time_ns
        while time.monotonic() < end:
            for _ in range(100):
                sent += 1
                put(payload, attachment=pack(sent, clock(), 16, gid))
        return sent
    send = sender.agent.send
    while time.monotonic() < end:
        for _ in range(100):
            send("hello")
        sent += 100
    return sent


def _send_latency(sender: _Sender) -> dict[int, int]:
    import numpy as np

    from pyconnect.codecs import wire

    image = np.zeros(SHAPE, dtype=np.uint8)
    sent: dict[int, int] = {}
    codec = wire.wire_codec("sensor_msgs/msg/Image")
    for seq in range(LATENCY_SAMPLES):
        image[0, :8, 0] = np.frombuffer(struct.pack("<q", seq), dtype=np.uint8)
        if sender.kind == "raw zenoh":
            payload = codec.encode(image)  # the same bytes a Peer puts on the wire
            sent[seq] = time.time_ns()
            sender.publisher.put(payload, attachment=struct.pack("<q", seq))
        else:
            sent[seq] = time.time_ns()
            sender.agent.send(image)
        time.sleep(LATENCY_PERIOD)
    return sent


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def main() -> None:
    print("zenoh peers vs zenoh's own Python pub/sub (the floor) and CustomNodes over DDS")
    rates: dict[str, Any] = {}
    for kind in RATE_KINDS:
        rates[kind] = _run_pair(kind, "rate")
    floor = rates["raw zenoh"].rate if rates["raw zenoh"] else 0.0
    print(
        f"\nsmall messages (std_msgs/String) received per second, sender flat out {RATE_SECONDS} s"
    )
    print(
        f"  {'pair':<17} {'msg/s':>9} {'vs raw':>7} {'received':>10} {'sent':>10} "
        f"{'lost*':>9} {'rx us/msg':>10} {'tx us/msg':>10}"
    )
    for kind in RATE_KINDS:
        row = rates[kind]
        if row is None:
            print(f"  {kind:<17} {'n/a (no connection)':>12}")
            continue
        ratio = row.rate / floor if floor else float("nan")
        lost = "-" if row.lost is None else f"{row.lost:,}"
        print(
            f"  {kind:<17} {row.rate:>9,.0f} {ratio:>6.2f}x {row.received:>10,} {row.sent:>10,} "
            f"{lost:>9} {row.receiver_us:>10.2f} {row.sender_us:>10.2f}"
        )
    print(
        "  lost*: what the receiving Peer counted (publisher sequence gaps: zenoh's congestion "
        "drops and keep-last); rx/tx us/msg: CPU of the receiving / sending process (all its "
        "threads) per message received / sent"
    )
    for kind, text in RATE_ROWS.items():
        print(f"  {kind}: {text}")
    print("  goal: pyconnect Peer >= 0.80x raw zenoh")
    print(
        f"\n1080p bgr8 Image one-way latency, {LATENCY_SAMPLES} samples every {LATENCY_PERIOD * 1000:.0f} ms"
    )
    print(f"  {'pair':<20} {'p50 ms':>9} {'p90 ms':>9} {'received':>9}")
    for kind in KINDS:
        latencies = _run_pair(kind, "latency")
        if not latencies:
            print(f"  {kind:<20} {'n/a':>9}")
            continue
        p50 = statistics.median(latencies)
        p90 = statistics.quantiles(latencies, n=10)[-1] if len(latencies) > 1 else p50
        print(f"  {kind:<20} {p50:>9.2f} {p90:>9.2f} {len(latencies):>9}")
    print("  goal: pyconnect Peer <= 5 ms p50")
    from bench import transport_stages

    transport_stages.main()


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "--receive":
        receive(sys.argv[2], sys.argv[3], sys.argv[4])
    else:
        main()
