"""Agents against raw rclpy, side by side in one run: ``python -m bench.agents``.

Rows: pub->sub small messages per second (a pyconnect ``sub`` decoding with the registry's
String codec vs a raw rclpy subscription on ``SingleThreadedExecutor``; target >= 90 %),
service round trip (pyconnect ``send()`` vs raw ``call_async`` + ``spin_until_future_complete``;
target <= 1.1x), action goal->result against a pyconnect action server vs a fresh raw rclpy
one, measured over 500 goals each (target <= 1.1x and flat: the last 50 goals as fast as the
first 50). Peers run in child processes of this module (``--peer MODE``).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from typing import Any

os.environ.setdefault("ROS_DOMAIN_ID", "47")
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

WINDOW = 3.0
CALLS = 300
GOALS = 500


# -- peers (child processes) ------------------------------------------------------------------
def peer(mode: str) -> None:
    import rclpy
    from rclpy.action import ActionServer
    from rclpy.node import Node
    from std_msgs.msg import String
    from std_srvs.srv import SetBool
    from test_msgs.action import Fibonacci

    if mode == "pyconnect_action":
        from pyconnect.ros.custom_node import CustomNode

        node = CustomNode("bench_pyconnect_action")
        node.add_agent(
            conn_name="bench_action",
            conn_type="action_server",
            data_interface=Fibonacci,
            response_func=lambda goal: {"sequence": [1]},
        )
        node.spin(run_thread=True)
        print("READY", flush=True)
        node.wait_for_shutdown()
        return
    rclpy.init()
    raw = Node(f"bench_{mode}")
    if mode == "blast":
        publisher = raw.create_publisher(String, "bench_chatter", 10)
        msg = String(data="x" * 16)
        print("READY", flush=True)
        try:
            while True:
                publisher.publish(msg)
        except KeyboardInterrupt:
            return
    if mode == "raw_service":

        def answer(request: Any, response: Any) -> Any:
            response.success = True
            return response

        raw.create_service(SetBool, "bench_service", answer)
    elif mode == "raw_action":

        def execute(goal_handle: Any) -> Any:
            goal_handle.succeed()
            return Fibonacci.Result(sequence=[1])

        ActionServer(raw, Fibonacci, "bench_action", execute)
    print("READY", flush=True)
    with suppress(KeyboardInterrupt):
        rclpy.spin(raw)


@contextmanager
def running(mode: str) -> Iterator[None]:
    child = subprocess.Popen(
        [sys.executable, "-m", "bench.agents", "--peer", mode],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    assert child.stdout is not None
    if child.stdout.readline().strip() != "READY":
        raise RuntimeError(f"peer {mode} did not start")
    try:
        yield
    finally:
        child.send_signal(2)
        try:
            child.wait(10)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
        child.stdout.close()


# -- measurements -----------------------------------------------------------------------------
def raw_sub_rate() -> float:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from std_msgs.msg import String

    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("bench_raw_sub", context=context)
    count = [0]
    node.create_subscription(
        String, "bench_chatter", lambda msg: count.__setitem__(0, count[0] + 1), 10
    )
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    # No timeout: rclpy builds a timer per spin_once(timeout_sec=...), which halves the rate.
    while count[0] == 0:
        executor.spin_once()
    start, first = time.perf_counter(), count[0]
    while time.perf_counter() - start < WINDOW:
        executor.spin_once()
    rate = (count[0] - first) / (time.perf_counter() - start)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=context)
    return rate


def pyconnect_sub_rate() -> float:
    import rclpy
    from std_msgs.msg import String

    from pyconnect.ros.custom_node import CustomNode

    node = CustomNode("bench_pyconnect_sub", context=rclpy.Context(), args=[], handle_signals=False)
    received = [0]

    def on_text(text: str) -> None:
        received[0] += 1

    sub = node.add_agent(
        conn_name="bench_chatter", conn_type="sub", data_interface=String, response_func=on_text
    )
    node.spin(run_thread=True)
    sub.wait_for_message(30)
    start, first = time.perf_counter(), received[0]
    node.wait_for_shutdown(timeout=WINDOW)
    rate = (received[0] - first) / (time.perf_counter() - start)
    assert isinstance(sub.get(), str)
    node.shutdown()
    return rate


def raw_service_rtt() -> float:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from std_srvs.srv import SetBool

    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("bench_raw_client", context=context)
    client = node.create_client(SetBool, "bench_service")
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    client.wait_for_service()
    times = []
    for index in range(CALLS + 20):
        start = time.perf_counter()
        future = client.call_async(SetBool.Request(data=True))
        # spin_until_future_complete costs ~10x more here; the plain loop is the stronger anchor.
        while not future.done():
            executor.spin_once()
        if index >= 20:
            times.append(time.perf_counter() - start)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=context)
    return statistics.mean(times)


def pyconnect_service_rtt(*, spin_thread: bool) -> float:
    import rclpy
    from std_srvs.srv import SetBool

    from pyconnect.ros.custom_node import CustomNode

    node = CustomNode(
        "bench_pyconnect_client", context=rclpy.Context(), args=[], handle_signals=False
    )
    client = node.add_agent(
        conn_name="bench_service", conn_type="service_client", data_interface=SetBool, timeout=10.0
    )
    if spin_thread:
        node.spin(run_thread=True)
    times = []
    for index in range(CALLS + 20):
        start = time.perf_counter()
        reply = client.send({"data": True})
        if index >= 20:
            times.append(time.perf_counter() - start)
    assert reply["isdone"] is True
    node.shutdown()
    return statistics.mean(times)


def action_latencies() -> list[float]:
    """Goal -> result times of GOALS goals from a raw rclpy client (the same for both servers)."""
    import rclpy
    from rclpy.action import ActionClient
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from test_msgs.action import Fibonacci

    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("bench_action_client", context=context)
    client = ActionClient(node, Fibonacci, "bench_action")
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    client.wait_for_server()
    times = []
    for _ in range(GOALS):
        start = time.perf_counter()
        goal_future = client.send_goal_async(Fibonacci.Goal(order=1))
        while not goal_future.done():
            executor.spin_once()
        result_future = goal_future.result().get_result_async()
        while not result_future.done():
            executor.spin_once()
        times.append(time.perf_counter() - start)
    client.destroy()
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=context)
    return times


def main() -> None:
    started = time.perf_counter()
    rows: list[tuple[str, float, float, str, str]] = []
    with running("blast"):
        # Interleaved, best of three each: the machine is shared, rates wander.
        raw_rates, pyc_rates = [], []
        for _ in range(3):
            raw_rates.append(raw_sub_rate())
            pyc_rates.append(pyconnect_sub_rate())
    raw_rate, pyc_rate = max(raw_rates), max(pyc_rates)
    rows.append(
        ("pub->sub small msgs/s", raw_rate, pyc_rate, f"{pyc_rate / raw_rate:.2f}", ">= 0.90")
    )
    with running("raw_service"):
        raw_rtt = raw_service_rtt()
        pyc_rtt = pyconnect_service_rtt(spin_thread=False)
        pyc_rtt_thread = pyconnect_service_rtt(spin_thread=True)
    rows.append(
        (
            "service round trip ms",
            raw_rtt * 1e3,
            pyc_rtt * 1e3,
            f"{pyc_rtt / raw_rtt:.2f}",
            "<= 1.10",
        )
    )
    rows.append(
        (
            "  (send() with spin thread) ms",
            raw_rtt * 1e3,
            pyc_rtt_thread * 1e3,
            f"{pyc_rtt_thread / raw_rtt:.2f}",
            "<= 1.10",
        )
    )
    with running("raw_action"):
        raw_goals = action_latencies()
    with running("pyconnect_action"):
        pyc_goals = action_latencies()
    first_raw, last_raw = statistics.mean(raw_goals[:50]), statistics.mean(raw_goals[-50:])
    first_pyc, last_pyc = statistics.mean(pyc_goals[:50]), statistics.mean(pyc_goals[-50:])
    rows.append(
        (
            "action goal->result ms (goals 1-50)",
            first_raw * 1e3,
            first_pyc * 1e3,
            f"{first_pyc / first_raw:.2f}",
            "<= 1.10",
        )
    )
    rows.append(
        (
            f"action goal->result ms (goals {GOALS - 49}-{GOALS})",
            last_raw * 1e3,
            last_pyc * 1e3,
            f"{last_pyc / last_raw:.2f}",
            "flat",
        )
    )
    rows.append(
        (
            "action growth last/first",
            last_raw / first_raw,
            last_pyc / first_pyc,
            "",
            "pyconnect ~1.0",
        )
    )
    print(f"{'measure':40} {'raw rclpy':>10} {'pyconnect':>10} {'ratio':>6}  target")
    for name, raw, pyc, ratio, target in rows:
        print(f"{name:40} {raw:10.3f} {pyc:10.3f} {ratio:>6}  {target}")
    print(f"({time.perf_counter() - started:.0f} s)")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--peer":
        peer(sys.argv[2])
    else:
        main()
