"""``python -m bench`` (``make bench``): every benchmark in one run, each printing its tables."""

from __future__ import annotations

import importlib
import sys
import time

# Order: pure-Python codecs first, then wire codecs and bags, then live ROS (the slowest).
BENCHMARKS = (
    "dict_codecs",
    "natural_codecs",
    "wire_codecs",
    "bag_reading",
    "tables",
    "agents",
    "large_messages",
    "sensor_qos",
    "transport",
)


def main(argv: list[str]) -> int:
    chosen = argv or list(BENCHMARKS)
    unknown = sorted(set(chosen) - set(BENCHMARKS))
    if unknown:
        print(f"unknown benchmark(s): {', '.join(unknown)}; choose from {', '.join(BENCHMARKS)}")
        return 2
    for name in chosen:
        print(f"\n===== bench.{name} =====", flush=True)
        started = time.perf_counter()
        importlib.import_module(f"bench.{name}").main()
        print(f"===== bench.{name}: {time.perf_counter() - started:.0f} s =====", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
