"""Fuzz the CDR wire codecs with mutated real and generated messages; print one report table.

``python -m tools.fuzz`` (``make fuzz``) runs ``--count`` byte strings (default 100,000) per codec
family: every generated type, the natural paths of Image, PointCloud2, JointState and
CompressedImage, and codecs compiled on the fly from the definitions stored in the shared bags.
Each byte string goes through ``to_dict``, ``decode_view`` and the natural ``decode``; each call
must return or raise a ``DecodeError`` whose text starts with the type's name, within 10 ms
(of CPU time when a run is re-timed: the wall clock of a loaded machine counts waiting),
allocating at most ``ALLOC_SLACK + ALLOC_FACTOR * len(input)`` bytes (tracemalloc; OpenCV's own
buffers are bounded by the peak RSS instead). The exit status is 1 when any check failed.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import os
import random
import resource
import sys
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pyconnect.codecs import wire
from pyconnect.errors import DecodeError
from tools import fuzz_corpus
from tools.mutate import mutate

HANG_SECONDS = 0.010
ALLOC_FACTOR = 64
"""Bytes a decoder may allocate per input byte (a 1-byte Empty in a sequence is a small dict)."""
ALLOC_SLACK = 64 * 1024
SAVE_DIR: Path | None = None
"""Where failing inputs are written (``--save DIR``), one file each."""
RSS_SLACK = 64 * 1024 * 1024
"""Peak-RSS growth allowed for one decode (native buffers such as OpenCV's are not traced)."""


@dataclass
class Target:
    """One codec under test, with the byte strings mutations start from."""

    name: str
    codec: wire.WireCodec
    seeds: list[bytes]


@dataclass
class Tally:
    family: str
    inputs: int = 0
    decoded: int = 0
    rejected: int = 0
    crashes: int = 0
    bad_paths: int = 0
    hangs: int = 0
    over_allocations: int = 0
    max_seconds: float = 0.0
    max_ratio: float = 0.0
    examples: dict[str, list[str]] = field(default_factory=dict)

    @property
    def failures(self) -> int:
        return self.crashes + self.bad_paths + self.hangs + self.over_allocations

    def note(self, text: str, data: bytes = b"") -> None:
        kind = text.split(" ", 1)[0]
        if SAVE_DIR is not None and data:
            SAVE_DIR.mkdir(parents=True, exist_ok=True)
            name = f"{kind.lower()}-{hashlib.sha1(data).hexdigest()[:12]}.cdr"
            (SAVE_DIR / f"{name}.txt").write_text(text + "\n")
            (SAVE_DIR / name).write_bytes(data)
        found = self.examples.setdefault(kind, [])
        if len(found) < 3:
            found.append(text)


def _names_the_type(text: str, msg_type: str) -> bool:
    short = msg_type.rsplit("/", 1)[-1]
    return text.startswith(msg_type) or text.startswith((f"{short}.", f"{short}:"))


def _calls(codec: wire.WireCodec) -> tuple[Callable[[bytes], Any], ...]:
    return codec.to_dict, codec.decode_view, codec.decode


def _retime(call: Callable[[bytes], Any], data: bytes) -> float:
    """The best of three untraced runs in CPU time of this thread: tracemalloc inflates one
    run, and on a loaded machine wall-clock time mostly counts waiting for a core."""
    tracemalloc.stop()
    best = float("inf")
    try:
        for _ in range(3):
            start = time.thread_time()
            with contextlib.suppress(Exception):
                call(data)
            best = min(best, time.thread_time() - start)
    finally:
        tracemalloc.start()
    return best


def _traced_again(call: Callable[[bytes], Any], data: bytes) -> int:
    tracemalloc.reset_peak()
    base = tracemalloc.get_traced_memory()[0]
    with contextlib.suppress(Exception):
        call(data)
    return tracemalloc.get_traced_memory()[1] - base


def check_one(tally: Tally, target: Target, data: bytes) -> None:
    """Decode ``data`` every way and record what the checks found."""
    tally.inputs += 1
    limit = ALLOC_SLACK + ALLOC_FACTOR * len(data)
    rejected = False
    for call in _calls(target.codec):
        rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        start = time.perf_counter()
        error: BaseException | None = None
        try:
            result = call(data)
            del result
        except DecodeError as caught:
            error = caught
        except Exception as caught:
            tally.crashes += 1
            kind = type(caught).__name__
            tally.note(f"CRASH {target.name} {kind}: {caught} <- {data.hex()[:160]}", data)
            return
        seconds = time.perf_counter() - start
        allocated = tracemalloc.get_traced_memory()[1] - base
        rss_grew = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss_before) * 1024
        if seconds > HANG_SECONDS:
            seconds = _retime(call, data)
            if seconds > HANG_SECONDS:
                tally.hangs += 1
                tally.note(f"HANG {target.name} {seconds * 1e3:.1f} ms <- {data.hex()[:160]}", data)
        tally.max_seconds = max(tally.max_seconds, seconds)
        tally.max_ratio = max(tally.max_ratio, allocated / max(len(data), 1))
        if allocated > limit:
            allocated = _traced_again(call, data)  # a first call may fill a cache
        if allocated > limit or rss_grew > RSS_SLACK:
            tally.over_allocations += 1
            tally.note(
                f"ALLOC {target.name} {allocated} B traced, peak RSS +{rss_grew} B for "
                f"{len(data)} B <- {data.hex()[:160]}",
                data,
            )
        if error is not None:
            rejected = True
            if not _names_the_type(str(error), target.codec.msg_type):
                tally.bad_paths += 1
                tally.note(f"PATH {target.name}: {error}")
    if rejected:
        tally.rejected += 1
    else:
        tally.decoded += 1


def _warm_up(targets: list[Target]) -> None:
    """Decode every seed once untimed, so lazy imports and caches are not charged to inputs."""
    for target in targets:
        for seed in target.seeds:
            for call in _calls(target.codec):
                with contextlib.suppress(Exception):
                    call(seed)


def run_family(family: str, targets: list[Target], count: int, rng: random.Random) -> Tally:
    tally = Tally(family)
    targets = [target for target in targets if target.seeds]
    everything = [seed for target in targets for seed in target.seeds]
    for index in range(count):
        target = targets[index % len(targets)]
        seed = rng.choice(target.seeds)
        # The unmutated seeds first: they must decode.
        data = seed if index < len(targets) else mutate(rng, seed, everything)
        check_one(tally, target, data)
    return tally


# -- families -------------------------------------------------------------------------------
def families(rng: random.Random, per_type: int) -> dict[str, list[Target]]:
    generated = [
        Target(name, wire.wire_codec(name), seeds)
        for name, seeds in fuzz_corpus.generated_seeds(rng, per_type).items()
    ]
    by_name = {target.name: target for target in generated}
    bag_targets: dict[tuple[str, str], Target] = {}
    for msg_type, text, encoding, cdr in fuzz_corpus.bag_messages():
        codec = wire.wire_codec(msg_type, definition=text, encoding=encoding)
        key = (msg_type, text)
        if key not in bag_targets:
            bag_targets[key] = Target(f"bag:{msg_type}", codec, [])
        bag_targets[key].seeds.append(cdr)
        # Real bytes seed the natural families too.
        if codec.msg_type in by_name:
            by_name[codec.msg_type].seeds.append(cdr)

    def natural(name: str, seeds: list[bytes]) -> list[Target]:
        return [Target(name, wire.wire_codec(name), seeds + by_name[name].seeds)]

    return {
        "generated types": generated,
        "Image (natural)": natural("sensor_msgs/msg/Image", fuzz_corpus.image_seeds(rng)),
        "PointCloud2 (natural)": natural(
            "sensor_msgs/msg/PointCloud2", fuzz_corpus.point_cloud_seeds(rng)
        ),
        "JointState (natural)": natural(
            "sensor_msgs/msg/JointState", fuzz_corpus.joint_state_seeds(rng)
        ),
        "CompressedImage (natural)": natural(
            "sensor_msgs/msg/CompressedImage", fuzz_corpus.compressed_image_seeds(rng)
        ),
        "bag definitions (on the fly)": list(bag_targets.values()),
    }


def report(tallies: list[Tally], seconds: float) -> str:
    header = (
        f"{'family':<30} {'inputs':>8} {'decoded':>8} {'rejected':>8} {'crashes':>7} "
        f"{'bad path':>8} {'hangs':>5} {'>alloc':>6} {'max ms':>7} {'max B/B':>8}"
    )
    lines = [header, "-" * len(header)]
    for t in tallies:
        lines.append(
            f"{t.family:<30} {t.inputs:>8} {t.decoded:>8} {t.rejected:>8} "
            f"{t.crashes:>7} {t.bad_paths:>8} {t.hangs:>5} {t.over_allocations:>6} "
            f"{t.max_seconds * 1e3:>7.2f} {t.max_ratio:>8.1f}"
        )
    lines.append(
        f"({seconds:.0f} s; each input decoded 3 ways: to_dict, decode_view, decode; "
        f"limits: {HANG_SECONDS * 1e3:.0f} ms, {ALLOC_SLACK // 1024} KiB + "
        f"{ALLOC_FACTOR} B per input byte traced, {RSS_SLACK >> 20} MiB peak RSS)"
    )
    for t in tallies:
        lines.extend(f"  {example}" for found in t.examples.values() for example in found)
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=100_000, help="byte strings per family")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--per-type", type=int, default=8, help="random seed messages per type")
    parser.add_argument("--family", action="append", help="only families whose name has this")
    parser.add_argument("--save", type=Path, help="write each failing input to this folder")
    options = parser.parse_args(argv)
    global SAVE_DIR  # noqa: PLW0603 (a script-wide option)
    SAVE_DIR = options.save
    rng = random.Random(options.seed)
    started = time.perf_counter()
    tallies = []
    missing = False
    chosen = families(rng, options.per_type)
    # Started after the codecs are compiled: tracing makes the compiler ten times slower.
    tracemalloc.start()
    for family, targets in chosen.items():
        if options.family and not any(part in family for part in options.family):
            continue
        if not any(target.seeds for target in targets):
            # The bag family's seeds are the sample bags: a clone without shared/ has none.
            print(f"{family}: skipped, no seed messages (sample bags at {fuzz_corpus.BAGS}?)")
            missing = True
            continue
        _warm_up(targets)
        tallies.append(run_family(family, targets, options.count, rng))
        # The table so far, after each family: a long run that is stopped still reports.
        print(report(tallies, time.perf_counter() - started), file=sys.stderr, flush=True)
    tracemalloc.stop()
    print(report(tallies, time.perf_counter() - started))
    if any(t.failures for t in tallies):
        return 1
    return 1 if missing and os.environ.get("CI") else 0  # CI must have the bags beside it


if __name__ == "__main__":
    sys.exit(main())
