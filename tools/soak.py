"""Soak: two processes exchange images, joint states, service calls and action goals for a while.

``python -m tools.soak [--minutes 30]`` (``make soak``; not in CI) starts ``tools.soak_peer``
twice: ``robot`` publishes 320x240 rgb8 images at 15 Hz and joint states at 50 Hz and serves a
SetBool service and a Fibonacci action with feedback; ``brain`` logs both topics to files
(PNG and JSON), records them to MCAP, calls the service at 10 Hz and sends a goal at 2 Hz.
This script samples both processes' RSS, open fds and threads, collects the latencies, and at
the end checks: RSS grew at most 5 % after warm-up (the first tenth, at least a minute), fds
and threads are flat, no call failed, no log entry was dropped, every recorded message is in
the bag, every log file is whole. Prints one table; exit 1 if a check failed.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from tools.storm import _check_logs

REPO = Path(__file__).resolve().parent.parent


def _status(pid: int) -> tuple[float, int, int]:
    """RSS in MiB, open fds and threads of a process (0s once it is gone)."""
    try:
        fields = dict(
            line.split(":", 1) for line in Path(f"/proc/{pid}/status").read_text().splitlines()
        )
        fds = len(os.listdir(f"/proc/{pid}/fd"))
    except (OSError, ValueError):
        return 0.0, 0, 0
    return int(fields["VmRSS"].split()[0]) / 1024, fds, int(fields["Threads"])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=30.0)
    parser.add_argument("--rows", type=int, default=10, help="rows of the table")
    options = parser.parse_args(argv)
    os.environ.setdefault("ROS_DOMAIN_ID", "88")
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    seconds = options.minutes * 60
    every = max(5.0, seconds / options.rows)
    warm_up = max(60.0, seconds / 10) if seconds >= 300 else seconds / 5
    with tempfile.TemporaryDirectory(prefix="pyconnect-soak-") as folder:
        out = Path(folder)
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        peer = [sys.executable, "-m", "tools.soak_peer"]
        robot = subprocess.Popen([*peer, "robot", "--seconds", str(seconds + 180)], cwd=REPO,
                                 env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                 text=True)  # fmt: skip
        brain_args = ["brain", "--seconds", str(seconds), "--every", str(every), "--out", str(out)]
        brain = subprocess.Popen([*peer, *brain_args], cwd=REPO, env=env, text=True,
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip
        rows: list[dict[str, Any]] = []
        final: dict[str, Any] = {}
        assert brain.stdout is not None
        for line in brain.stdout:
            record = json.loads(line)
            if record.get("final"):
                final = record
                continue
            record["robot"], record["brain"] = _status(robot.pid), _status(brain.pid)
            rows.append(record)
            print(json.dumps(record), file=sys.stderr, flush=True)
        brain_err = brain.stderr.read() if brain.stderr else ""
        brain.wait()
        robot.terminate()
        robot_err = robot.communicate(timeout=60)[1]
        bag_count = _bag_count(out / "soak.mcap")
        log_files, log_problems = _check_logs(out / "logs") if (out / "logs").exists() else (0, [])
    print(table(rows, final, warm_up))
    checks = verdict(rows, final, warm_up, bag_count=bag_count, log_files=log_files,
                     log_problems=log_problems)  # fmt: skip
    checks["brain exit 0, no traceback"] = brain.returncode == 0 and "Traceback" not in brain_err
    checks["robot ended, no traceback"] = "Traceback" not in robot_err
    for name, ok in checks.items():
        print(f"{'ok  ' if ok else 'FAIL'} {name}")
    if not all(checks.values()):
        print(brain_err[-2000:], robot_err[-2000:], sep="\n")
    return 0 if all(checks.values()) else 1


def _bag_count(path: Path) -> int:
    from pyconnect.record.bag_reader import open_bag

    if not path.exists():
        return -1
    with open_bag(path, natural=False) as bag:
        return sum(1 for _ in bag)


def table(rows: list[dict[str, Any]], final: dict[str, Any], warm_up: float) -> str:
    head = (f"{'t s':>6} {'robot MiB':>9} {'brain MiB':>9} {'fds r/b':>8} {'thr r/b':>8} "
            f"{'calls':>6} {'svc p50/p99 ms':>15} {'goals':>5} {'act p50/p99 ms':>15} "
            f"{'images':>7} {'joints':>7}")  # fmt: skip
    lines = [head, "-" * len(head)]
    for row in rows:
        robot, brain = row["robot"], row["brain"]
        svc, act = row["service_ms"], row["action_ms"]
        mark = "*" if row["t"] <= warm_up else " "
        lines.append(
            f"{row['t']:>5.0f}{mark} {robot[0]:>9.1f} {brain[0]:>9.1f} "
            f"{f'{robot[1]}/{brain[1]}':>8} {f'{robot[2]}/{brain[2]}':>8} {row['calls']:>6} "
            f"{_ms(svc):>15} {row['goals']:>5} {_ms(act):>15} "
            f"{row['received']['camera']:>7} {row['received']['joints']:>7}"
        )
    lines.append("(* warm-up)  final: " + json.dumps(final))
    return "\n".join(lines)


def _ms(pair: list[float]) -> str:
    return "-" if any(math.isnan(v) for v in pair) else f"{pair[0]:.1f}/{pair[1]:.1f}"


def verdict(
    rows: list[dict[str, Any]],
    final: dict[str, Any],
    warm_up: float,
    *,
    bag_count: int,
    log_files: int,
    log_problems: list[str],
) -> dict[str, bool]:
    after = [row for row in rows if row["t"] > warm_up]
    checks: dict[str, bool] = {"brain reported": bool(final) and bool(after)}
    if not checks["brain reported"]:
        return checks
    for side in ("robot", "brain"):
        base, last = after[0][side], after[-1][side]
        checks[f"{side} RSS flat (<= +5 % after warm-up: {base[0]:.1f} -> {last[0]:.1f} MiB)"] = (
            last[0] <= base[0] * 1.05
        )
        checks[f"{side} fds and threads flat ({base[1]}->{last[1]}, {base[2]}->{last[2]})"] = (
            last[1] <= base[1] + 2 and last[2] <= base[2] + 2
        )
    checks[f"no failed calls {final['failures']}"] = not any(final["failures"].values())
    logged = final["logged"]
    drops = sum((entry or {}).get("dropped", 0) + (entry or {}).get("failed", 0)
                for entry in logged.values())  # fmt: skip
    written = sum((entry or {}).get("written", 0) for entry in logged.values())
    checks[f"log drops = 0 ({drops}), {written} written, {log_files} files"] = (
        drops == 0 and written == log_files
    )
    checks[f"every recorded message in the bag ({final['recorded']} -> {bag_count})"] = (
        final["recorded"] == bag_count > 0
    )
    checks[f"all log files valid ({len(log_problems)} problems)"] = not log_problems
    return checks


if __name__ == "__main__":
    sys.exit(main())
