"""The elastic executor: blocking callbacks hand spinning over, agents do not block each other."""

from __future__ import annotations

import threading
from typing import Any

from std_msgs.msg import String
from std_srvs.srv import Trigger

from .conftest import EVENT_TIMEOUT, repeat_until


def test_response_func_may_call_a_blocking_service(make_node: Any) -> None:
    node = make_node()
    node.add_agent(
        conn_name="lookup",
        conn_type="service_server",
        data_interface=Trigger,
        response_func=lambda _request: {"success": True, "message": "found"},
    )
    client = node.add_agent(
        conn_name="lookup",
        agent_name="lookup_client",
        conn_type="service_client",
        data_interface=Trigger,
    )
    answers: list[Any] = []
    answered = threading.Event()

    def on_command(_value: str) -> None:
        answers.append(client.send({}, timeout=EVENT_TIMEOUT))
        answered.set()

    node.add_agent(
        conn_name="command", conn_type="sub", data_interface=String, response_func=on_command
    )
    pub = node.add_agent(
        conn_name="command", agent_name="out", conn_type="pub", data_interface=String
    )
    node.spin(run_thread=True)
    assert repeat_until(answered, lambda: pub.send("go"))
    assert answers[0] == {"success": True, "message": "found", "isdone": True}


def test_a_slow_agent_does_not_block_another(make_node: Any) -> None:
    node = make_node()
    release_slow = threading.Event()
    slow_started = threading.Event()
    fast_seen = threading.Event()

    def slow(_value: str) -> None:
        slow_started.set()
        # Blocks until the fast agent has been served meanwhile (or the test gives up).
        release_slow.wait(EVENT_TIMEOUT)

    def fast(_value: str) -> None:
        if slow_started.is_set():
            fast_seen.set()
            release_slow.set()

    node.add_agent(conn_name="images", conn_type="sub", data_interface=String, response_func=slow)
    node.add_agent(conn_name="imu", conn_type="sub", data_interface=String, response_func=fast)
    images = node.add_agent(
        conn_name="images", agent_name="images_out", conn_type="pub", data_interface=String
    )
    imu = node.add_agent(
        conn_name="imu", agent_name="imu_out", conn_type="pub", data_interface=String
    )
    node.spin(run_thread=True)
    assert repeat_until(slow_started, lambda: images.send("frame"))
    assert repeat_until(fast_seen, lambda: imu.send("sample"))
    assert release_slow.is_set()


def test_one_agent_handles_its_messages_in_order(make_node: Any) -> None:
    node = make_node()
    seen: list[int] = []
    done = threading.Event()
    in_callback = threading.Lock()
    overlaps: list[int] = []

    def handle(value: str) -> None:
        if not in_callback.acquire(blocking=False):
            overlaps.append(1)
            return
        try:
            seen.append(int(value))
            if len(seen) >= 50:
                done.set()
        finally:
            in_callback.release()

    node.add_agent(
        conn_name="seq", conn_type="sub", data_interface=String, response_func=handle, qos=100
    )
    pub = node.add_agent(
        conn_name="seq", agent_name="out", conn_type="pub", data_interface=String, qos=100
    )
    node.spin(run_thread=True)
    ready = threading.Event()
    node.add_agent(
        conn_name="seq",
        agent_name="probe",
        conn_type="sub",
        data_interface=String,
        response_func=lambda _value: ready.set(),
    )
    assert repeat_until(ready, lambda: pub.send("-1"))
    seen.clear()
    for number in range(50):
        pub.send(str(number))
    assert done.wait(EVENT_TIMEOUT)
    assert overlaps == []
    assert seen == sorted(seen)
