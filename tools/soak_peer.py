"""One side of the soak (``tools.soak``): ``robot`` serves, ``brain`` subscribes, logs, records
and calls; ``brain`` prints a JSON line of figures every ``--every`` seconds and at the end."""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from sensor_msgs.msg import Image, JointState
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci

from pyconnect.ros.custom_node import CustomNode

JOINTS = [f"joint_{index}" for index in range(7)]


def robot(seconds: float) -> None:
    node = CustomNode("soak_robot", args=[])
    frames = [np.full((240, 320, 3), shade, np.uint8) for shade in range(0, 250, 25)]
    tick = {"n": 0}

    def next_frame() -> Any:
        tick["n"] += 1
        return frames[tick["n"] % len(frames)]

    def joints() -> dict[str, float]:
        now = time.monotonic()
        return {name: math.sin(now + index) for index, name in enumerate(JOINTS)}

    def count(goal: dict[str, Any], publish_feedback: Any) -> dict[str, Any]:
        sequence = [0, 1]
        for _ in range(goal["order"]):
            sequence.append(sequence[-1] + sequence[-2])
            publish_feedback({"sequence": sequence})
        return {"sequence": sequence}

    node.add_agent(conn_name="camera", conn_type="pub", data_interface=Image,
                   time_period=1 / 15, response_func=next_frame)  # fmt: skip
    node.add_agent(conn_name="joint_states", conn_type="pub", data_interface=JointState,
                   time_period=1 / 50, response_func=joints)  # fmt: skip
    node.add_agent(conn_name="toggle", conn_type="service_server", data_interface=SetBool,
                   response_func=lambda r: {"success": r["data"], "message": "ok"})  # fmt: skip
    node.add_agent(conn_name="count", conn_type="action_server", data_interface=Fibonacci,
                   response_func=count)  # fmt: skip
    node.spin(run_thread=True)
    node.wait_for_shutdown(timeout=seconds)
    node.shutdown()


def _percentiles(values: list[float]) -> tuple[float, float]:
    if not values:
        return math.nan, math.nan
    ordered = sorted(values)
    return ordered[len(ordered) // 2], ordered[min(len(ordered) - 1, int(len(ordered) * 0.99))]


def brain(seconds: float, every: float, out: Path) -> None:
    node = CustomNode("soak_brain", args=[], log_dir=out / "logs")
    camera = node.add_agent(conn_name="camera", conn_type="sub", data_interface=Image,
                            do_log_msg=True)  # fmt: skip
    joints = node.add_agent(conn_name="joint_states", conn_type="sub",
                            data_interface=JointState, do_log_msg=True)  # fmt: skip
    client = node.add_agent(conn_name="toggle", agent_name="toggle_client",
                            conn_type="service_client", data_interface=SetBool,
                            timeout=10.0)  # fmt: skip
    goals = node.add_agent(conn_name="count", agent_name="count_client",
                           conn_type="action_client", data_interface=Fibonacci,
                           timeout=10.0)  # fmt: skip
    node.spin(run_thread=True)
    node.wait_until_connected(timeout=120.0)
    recording = node.record(out / "soak.mcap", topics=["/camera", "/joint_states"])
    lock = threading.Lock()
    latencies: dict[str, list[float]] = {"service": [], "action": []}
    failures = {"service": 0, "action": 0}
    errors: list[str] = []
    stop = threading.Event()

    def call_loop(kind: str, period: float) -> None:
        while not stop.wait(period):
            start = time.perf_counter()
            if kind == "service":
                reply = client.send({"data": True})
                ok = isinstance(reply, dict) and reply.get("success") is True
            else:
                reply = goals.send({"order": 5})
                ok = isinstance(reply, dict) and reply.get("isdone") is True
            with lock:
                if ok:
                    latencies[kind].append((time.perf_counter() - start) * 1e3)
                else:
                    failures[kind] += 1
                    errors.append(str(reply)[:300])

    workers = [threading.Thread(target=call_loop, args=("service", 0.1), daemon=True),
               threading.Thread(target=call_loop, args=("action", 0.5), daemon=True)]  # fmt: skip
    for worker in workers:
        worker.start()
    started = time.monotonic()
    while time.monotonic() - started < seconds:
        time.sleep(min(every, max(0.0, seconds - (time.monotonic() - started))))
        with lock:
            service, action = latencies["service"], latencies["action"]
            latencies = {"service": [], "action": []}
        received = {"camera": camera.message_count, "joints": joints.message_count}
        line = {"t": round(time.monotonic() - started, 1),
                "service_ms": _percentiles(service), "action_ms": _percentiles(action),
                "calls": len(service), "goals": len(action), "received": received}  # fmt: skip
        print(json.dumps(line), flush=True)
    stop.set()
    for worker in workers:
        worker.join(15.0)
    received = {"camera": camera.message_count, "joints": joints.message_count}
    recording.stop()
    node.shutdown()  # flushes and closes the message loggers
    loggers = {name: agent._message_logger for name, agent in (("camera", camera),
                                                                ("joints", joints))}  # fmt: skip
    final = {"final": True, "received": received, "recorded": recording.messages_written,
             "failures": failures, "errors": errors[:5],
             "logged": {name: None if lg is None else {"written": lg.written,
                                                       "dropped": lg.dropped,
                                                       "failed": lg.failed}
                        for name, lg in loggers.items()}}  # fmt: skip
    print(json.dumps(final), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("role", choices=("robot", "brain"))
    parser.add_argument("--seconds", type=float, required=True)
    parser.add_argument("--every", type=float, default=10.0)
    parser.add_argument("--out", type=Path, default=Path("."))
    options = parser.parse_args()
    if options.role == "robot":
        robot(options.seconds)
    else:
        brain(options.seconds, options.every, options.out)
    sys.stdout.flush()


if __name__ == "__main__":
    main()
