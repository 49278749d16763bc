"""``make demo``: start the simulated robot process and the brain, run ~15 s, stop cleanly.

The robot (``examples.demo_robot``) runs as a child process; the brain
(``examples.demo_brain``) runs here. Both print what they do; logs go to ``./pyconnect_logs``
(or ``$PYCONNECT_LOG_DIR``). Exit code 0 when both ended cleanly.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys

from examples import demo_brain

DURATION = 12.0


def main() -> int:
    # Keep the demo off other ROS graphs on the network unless the user chose otherwise.
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    robot = subprocess.Popen(
        [sys.executable, "-m", "examples.demo_robot"],
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
        # Its own session: a Ctrl-C reaches the demo only, which then stops the robot once.
        start_new_session=True,
    )
    assert robot.stdout is not None
    if robot.stdout.readline().strip() != "READY":
        print("[demo] the robot did not start", file=sys.stderr)
        robot.kill()
        return 1
    print("[demo] robot process is up; starting the brain", flush=True)
    relay = _relay(robot.stdout)
    try:
        demo_brain.run(DURATION)
    finally:
        if robot.poll() is None:
            robot.send_signal(signal.SIGINT)
        code = robot.wait(30)
        relay.join(5)
        robot.stdout.close()
    print(f"[demo] robot exited with {code}; done", flush=True)
    return 0 if code == 0 else 1


def _relay(stream: object) -> object:
    import threading

    def copy() -> None:
        for line in stream:  # type: ignore[attr-defined]
            print(line, end="", flush=True)

    thread = threading.Thread(target=copy, daemon=True)
    thread.start()
    return thread


if __name__ == "__main__":
    sys.exit(main())
