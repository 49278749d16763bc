"""Signal storms: end a busy node 100 times, each a different way at a random moment.

``python -m tools.storm [--runs 100]`` (``make storm``) starts ``tools.storm_child`` again and
again: a node publishing images at 50 Hz to its own logging subscriber, a service call and an
action goal (with feedback) always in flight, and a 100 Hz timer. Each run ends by SIGINT,
SIGTERM, ``node.shutdown()``, leaving ``with`` or interpreter exit (in turn), 0-1.5 s after the
node is busy. A run passes when it exits 0 with no traceback and no ``terminate called``,
``stop_func`` ran exactly once, no pyconnect thread outlived the node (the process-wide idle
log writer excepted), no Fast DDS shared-memory segment of its own is left in /dev/shm, and
every log file is whole (it decodes) with no temporary file left. Prints one table; exit 1 if
any run failed.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ENDINGS = ("sigint", "sigterm", "shutdown", "with", "exit")
SIGNALS = {"sigint": signal.SIGINT, "sigterm": signal.SIGTERM}
ALLOWED_THREADS = {"pyconnect-log-writer"}
"""Process-wide threads that may outlive a node (an idle daemon, one per process)."""
READY_TIMEOUT = 180.0
EXIT_TIMEOUT = 60.0


@dataclass
class Run:
    ending: str
    delay: float
    code: int | None = None
    seconds: float = 0.0
    problems: list[str] = field(default_factory=list)
    log_files: int = 0


def _shm_of(pid: int) -> set[str]:
    """The Fast DDS shared-memory segments a process owns (mapped, and not a port's).

    ``fastrtps_port<N>`` segments are the mailboxes of a port, shared by every process that
    listens on it (other programs on the machine too), so their lifetime is not this process's.
    """
    try:
        maps = Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return set()
    return {
        line.split()[-1]
        for line in maps.splitlines()
        if "/dev/shm/fastrtps_" in line and "/dev/shm/fastrtps_port" not in line
    }


def _mapped_elsewhere(path: str) -> bool:
    """Whether a live process maps ``path``: a participant also maps the segments of the peers
    it talks to, which live as long as those peers (other programs on the machine)."""
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            if path in Path(f"/proc/{entry}/maps").read_text():
                return True
        except OSError:
            continue
    return False


def _check_logs(root: Path) -> tuple[int, list[str]]:
    """How many log files, and which are not whole (or are temporaries left behind)."""
    import cv2

    problems = []
    count = 0
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        count += 1
        name = path.name
        try:
            if name.startswith(".") or name.endswith(".tmp"):
                problems.append(f"temporary file left: {path.relative_to(root)}")
            elif path.suffix == ".png":
                if cv2.imread(str(path), cv2.IMREAD_UNCHANGED) is None:
                    problems.append(f"broken png: {path.relative_to(root)}")
            elif path.suffix == ".json":
                json.loads(path.read_text())
            elif path.suffix == ".npy":
                np.load(path)
        except (ValueError, OSError) as error:
            problems.append(f"broken {path.suffix}: {path.relative_to(root)} ({error})")
    return count, problems


def one_run(ending: str, delay: float, work: Path, repo: Path) -> Run:
    run = Run(ending, delay)
    logs = work / "logs"
    out_path, err_path = work / "stdout.txt", work / "stderr.txt"
    started = time.monotonic()
    with out_path.open("w") as out, err_path.open("w") as err:
        child = subprocess.Popen(
            [sys.executable, "-m", "tools.storm_child", ending, f"{delay:.3f}", str(logs)],
            stdout=out, stderr=err, cwd=repo, env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )  # fmt: skip
        mapped: set[str] = set()
        deadline = time.monotonic() + READY_TIMEOUT
        while time.monotonic() < deadline and child.poll() is None:
            if "READY" in out_path.read_text():
                break
            time.sleep(0.02)
        else:
            if child.poll() is None:
                # A signal now would meet Python before pyconnect (the machine is too slow).
                child.kill()
                child.wait()
                run.problems.append(f"never became ready within {READY_TIMEOUT:.0f} s")
                run.seconds = time.monotonic() - started
                return run
        mapped = _shm_of(child.pid)
        if ending in SIGNALS and child.poll() is None:
            time.sleep(delay)
            mapped |= _shm_of(child.pid)
            child.send_signal(SIGNALS[ending])
        try:
            run.code = child.wait(EXIT_TIMEOUT)
        except subprocess.TimeoutExpired:
            run.problems.append(f"hung: still running {EXIT_TIMEOUT:.0f} s after its ending")
            child.kill()
            run.code = child.wait()
    run.seconds = time.monotonic() - started
    out, err = out_path.read_text(), err_path.read_text()
    lines = out.split("\n")
    if run.code != 0:
        run.problems.append(f"exit code {run.code}")
    if "Traceback" in err:
        run.problems.append("traceback: " + err[err.index("Traceback") :][:600])
    if "terminate called" in err:
        run.problems.append("terminate called")
    if lines.count("STOP") != 1:
        run.problems.append(f"stop_func ran {lines.count('STOP')} times")
    threads = [line[8:] for line in lines if line.startswith("THREADS ")]
    if not threads:
        run.problems.append("no THREADS line (atexit did not run)")
    else:
        left = {
            name for name in threads[-1].split(",")
            if name != "-" and not name.startswith("user-") and name not in ALLOWED_THREADS
        }  # fmt: skip
        if left:
            run.problems.append(f"threads left: {sorted(left)}")
    leaked = sorted(path for path in mapped if os.path.exists(path) and not _mapped_elsewhere(path))
    if leaked:
        run.problems.append(f"/dev/shm left: {leaked}")
    run.log_files, log_problems = _check_logs(logs) if logs.exists() else (0, [])
    run.problems.extend(log_problems)
    return run


def report(runs: list[Run]) -> str:
    header = (
        f"{'ending':<9} {'runs':>5} {'exit 0':>7} {'clean':>6} {'failed':>6} {'log files':>9} "
        f"{'mean s':>7}"
    )
    lines = [header, "-" * len(header)]
    for ending in ENDINGS:
        mine = [run for run in runs if run.ending == ending]
        if not mine:
            continue
        lines.append(
            f"{ending:<9} {len(mine):>5} {sum(r.code == 0 for r in mine):>7} "
            f"{sum(not r.problems for r in mine):>6} {sum(bool(r.problems) for r in mine):>6} "
            f"{sum(r.log_files for r in mine):>9} {sum(r.seconds for r in mine) / len(mine):>7.1f}"
        )
    lines.append(
        f"{'all':<9} {len(runs):>5} {sum(r.code == 0 for r in runs):>7} "
        f"{sum(not r.problems for r in runs):>6} {sum(bool(r.problems) for r in runs):>6} "
        f"{sum(r.log_files for r in runs):>9}"
    )
    kinds = Counter(problem.split(":")[0] for run in runs for problem in run.problems)
    for kind, count in kinds.most_common():
        lines.append(f"  {count} x {kind}")
    for run in runs:
        for problem in run.problems[:2]:
            lines.append(f"  [{run.ending} after {run.delay:.2f} s] {problem}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--max-delay", type=float, default=1.5)
    options = parser.parse_args(argv)
    os.environ.setdefault("ROS_DOMAIN_ID", "88")
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    rng = random.Random(options.seed)
    repo = Path(__file__).resolve().parent.parent
    runs = []
    for index in range(options.runs):
        ending = ENDINGS[index % len(ENDINGS)]
        with tempfile.TemporaryDirectory(prefix="pyconnect-storm-") as work:
            run = one_run(ending, rng.uniform(0.0, options.max_delay), Path(work), repo)
        runs.append(run)
        print(f"run {index + 1}/{options.runs}: {ending} after {run.delay:.2f} s: "
              f"{'ok' if not run.problems else run.problems[0][:200]}",
              file=sys.stderr, flush=True)  # fmt: skip
    print(report(runs))
    return 1 if any(run.problems for run in runs) else 0


if __name__ == "__main__":
    sys.exit(main())
