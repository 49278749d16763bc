"""Where a peer's small-message time goes: each stage of send and receive, side by side in one process.

``python -m bench.transport_stages`` (``bench.transport`` prints it after its rate table). Two
peers in this process meet on a loopback port; the receiving stages run on samples zenoh
really delivered (captured once, then replayed), so attachment and payload objects are the
real ones. Times are wall-clock per call of this thread, best of several rounds in turns
(``bench.timing.compare``); zenoh's own threads (sending, receiving) run beside it.

Sender anchor: the raw floor's ``put(bytes)``. Receiver anchor: the raw floor's callback body
(count the sample: what bench.transport's raw zenoh receiver does per sample).
"""

from __future__ import annotations

import itertools
import time
from typing import Any

import zenoh

from bench.timing import compare

CAPTURED = 2000


def main() -> None:
    from bench.transport import _free_port, _zenoh_config
    from pyconnect.transport import Peer
    from pyconnect.transport import rmw_zenoh_keys as keys
    from pyconnect.transport.conversion import WireConversion

    locator = f"tcp/127.0.0.1:{_free_port()}"
    receiver = Peer("stages_rx", config=_zenoh_config(locator, listen=True))
    sender = Peer("stages_tx", config=_zenoh_config(locator, listen=False))
    try:
        handled: list[Any] = []
        sub: Any = receiver.add_agent(
            conn_name="stages",
            conn_type="sub",
            data_interface="std_msgs/msg/String",
            response_func=handled.append,
        )
        pub: Any = sender.add_agent(
            conn_name="stages", conn_type="pub", data_interface="std_msgs/msg/String"
        )
        deadline = time.monotonic() + 30
        while pub.subscriber_count == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        capture = receiver.session.declare_subscriber(
            sub.key, zenoh.handlers.FifoChannel(CAPTURED + 100)
        )
        time.sleep(0.5)
        for _ in range(CAPTURED):
            pub.send("hello")
            time.sleep(0)  # let zenoh's threads run: no congestion drops
        samples: list[Any] = []
        while len(samples) < CAPTURED and time.monotonic() < deadline + 30:
            sample = capture.handler.try_recv()
            if sample is None:
                time.sleep(0.01)
                continue
            samples.append(sample)
        capture.undeclare()
        general = WireConversion(
            describe="stages", codec=pub.conversion.codec, registry=sender.registry, fast=False
        )
        _sender_stages(pub, general, keys)
        _receiver_stages(sub, general, samples, handled)
    finally:
        sender.shutdown()
        receiver.shutdown()


def _sender_stages(pub: Any, general: Any, keys: Any) -> None:
    payload = pub.conversion.encode("hello")
    attachment = keys.pack_attachment(1, time.time_ns(), pub.gid)
    put, pack, gid, encode = pub._put, keys.ATTACHMENT.pack, pub.gid, pub.conversion.encode
    sequence = itertools.count(1)
    compare(
        "Peer sender stages (std_msgs/String 'hello'), per message",
        [
            ("raw floor: publisher.put(bytes)", lambda: put(payload)),
            (
                "put(bytes, attachment=<rmw_zenoh's 33 bytes>)",
                lambda: put(payload, attachment=attachment),
            ),
            (
                "attachment: pack(sequence, time_ns(), 16, gid)",
                lambda: pack(next(sequence), time.time_ns(), 16, gid),
            ),
            ("encode 'hello' (fast path)", lambda: encode("hello")),
            ("encode 'hello' (general path: codec + generated)", lambda: general.encode("hello")),
            ("whole agent.send('hello')", lambda: pub.send("hello")),
        ],
    )


def _receiver_stages(sub: Any, general: Any, samples: list[Any], handled: list[Any]) -> None:
    from pyconnect.transport import topic_subscriber

    idle = sub.peer.session.declare_subscriber("stages/idle", zenoh.handlers.RingChannel(1))
    try_recv = idle.handler.try_recv

    replay = itertools.cycle(samples)
    payloads = itertools.cycle([sample.payload.to_bytes() for sample in samples])
    counted: list[tuple[int, int]] = []

    def raw_floor() -> None:  # bench.transport's raw receiver: note(0) per sample
        next(replay)
        counted.append((0, time.time_ns()))
        if len(counted) > 100_000:
            counted.clear()

    def attachment() -> None:
        attached = next(replay).attachment
        topic_subscriber._unpack_attachment(attached.to_bytes())

    decode, on_sample = sub.conversion.decode, sub._on_sample

    def payload() -> None:
        next(replay).payload.to_bytes()

    def whole() -> None:
        on_sample(next(replay))
        if len(handled) > 100_000:
            handled.clear()

    compare(
        "Peer receiver stages (std_msgs/String 'hello'), per message",
        [
            ("raw floor: count the sample (the bench's callback)", raw_floor),
            ("hand-off: ring.try_recv() (releases the GIL)", try_recv),
            ("sample.attachment -> bytes -> unpack", attachment),
            ("sample.payload.to_bytes()", payload),
            ("decode to str (fast path)", lambda: decode(next(payloads))),
            ("decode to str (general path: view + codec)", lambda: general.decode(next(payloads))),
            ("whole sample: check, decode, count, response_func", whole),
        ],
    )
    idle.undeclare()


if __name__ == "__main__":
    main()
