"""One storm run: a node with every agent kind busy, ended one way (see ``tools.storm``).

``python -m tools.storm_child ENDING DELAY LOG_DIR``: ENDING is sigint, sigterm (the parent
signals after READY), shutdown, with or exit (this process ends itself DELAY s after READY).
Prints READY, STOP (from stop_func), AFTER when the main code runs past the ending, and at
the very end THREADS with the threads still alive.
"""

from __future__ import annotations

import atexit
import sys
import threading
import time
from typing import Any


def say(word: str) -> None:
    sys.stdout.write(word + "\n")  # one write per line: threads print too
    sys.stdout.flush()


def _threads_left() -> None:
    alive = sorted(t.name for t in threading.enumerate() if t is not threading.main_thread())
    say("THREADS " + (",".join(alive) or "-"))


# Registered before any node: atexit runs it last, after the node's own shutdown hook.
atexit.register(_threads_left)

import numpy as np  # noqa: E402
from sensor_msgs.msg import Image  # noqa: E402
from std_srvs.srv import SetBool  # noqa: E402
from test_msgs.action import Fibonacci  # noqa: E402

from pyconnect.ros.custom_node import CustomNode  # noqa: E402


def build(log_dir: str) -> tuple[CustomNode, threading.Event]:
    node = CustomNode("storm_node", stop_func=lambda: say("STOP"), log_dir=log_dir, args=[])
    frame = np.random.default_rng(0).integers(0, 255, (48, 64, 3), dtype=np.uint8)
    seen = {"image": threading.Event(), "service": threading.Event(),
            "feedback": threading.Event(), "tick": threading.Event()}  # fmt: skip
    ready = threading.Event()

    def mark(name: str) -> None:
        seen[name].set()
        if all(event.is_set() for event in seen.values()):
            ready.set()

    def toggle(request: dict[str, Any]) -> dict[str, Any]:
        time.sleep(0.02)  # keeps a call in flight most of the time
        return {"success": request["data"], "message": "ok"}

    def count(goal: dict[str, Any], publish_feedback: Any) -> dict[str, Any]:
        sequence = [0, 1]
        for _ in range(goal["order"]):
            sequence.append(sequence[-1] + sequence[-2])
            publish_feedback({"sequence": sequence})
            time.sleep(0.01)
        return {"sequence": sequence}

    node.add_agent(conn_name="camera", conn_type="pub", data_interface=Image, time_period=0.02,
                   response_func=lambda: frame)  # fmt: skip
    node.add_agent(conn_name="camera", agent_name="camera_sub", conn_type="sub",
                   data_interface=Image, do_log_msg=True,
                   response_func=lambda _image: mark("image"))  # fmt: skip
    node.add_agent(conn_name="toggle", conn_type="service_server", data_interface=SetBool,
                   response_func=toggle)  # fmt: skip
    client = node.add_agent(conn_name="toggle", agent_name="toggle_client",
                            conn_type="service_client", data_interface=SetBool)  # fmt: skip
    node.add_agent(conn_name="count", conn_type="action_server", data_interface=Fibonacci,
                   response_func=count)  # fmt: skip
    goals = node.add_agent(conn_name="count", agent_name="count_client",
                           conn_type="action_client", data_interface=Fibonacci,
                           feedback_func=lambda _value: mark("feedback"))  # fmt: skip
    node.add_agent(conn_name="tick", conn_type="timer", time_period=0.01,
                   response_func=lambda: mark("tick"))  # fmt: skip

    def call_forever() -> None:
        while node.ok():
            reply = client.send({"data": True}, timeout=5.0)
            if isinstance(reply, dict) and reply.get("success"):
                mark("service")

    def goals_forever() -> None:
        while node.ok():
            goals.send({"order": 20}, timeout=5.0)

    node.spin(run_thread=True)
    for work in (call_forever, goals_forever):
        threading.Thread(target=work, name=f"user-{work.__name__}", daemon=True).start()
    return node, ready


def main() -> None:
    ending, delay, log_dir = sys.argv[1], float(sys.argv[2]), sys.argv[3]
    node, ready = build(log_dir)
    if not ready.wait(60):
        say("NOT READY")
    if ending == "with":
        with node:
            say("READY")
            time.sleep(delay)
        say("AFTER")
        return
    say("READY")
    if ending in ("sigint", "sigterm"):
        if delay < 0.5:
            node.spin()  # the signal finds the main thread waiting here
        else:
            while True:
                time.sleep(0.01)  # ... or in the user's own loop
        say("AFTER")
        return
    time.sleep(delay)
    if ending == "shutdown":
        node.shutdown()
        say("AFTER")
    # "exit": the interpreter ends with the node running; atexit shuts it down.


if __name__ == "__main__":
    main()
