"""The ElasticExecutor's kept wait set: built once, one wait per callback, handles let go, events."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import pytest
import rclpy
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.exceptions import InvalidHandle
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
from std_srvs.srv import Trigger

from pyconnect.ros.executor import ElasticExecutor
from pyconnect.ros.wait_plan import COOL_AFTER

from .conftest import EVENT_TIMEOUT, repeat_until


@pytest.fixture(params=[COOL_AFTER, 0.05], ids=["default", "quick_cooling"])
def spun(request: pytest.FixtureRequest) -> Iterator[tuple[Node, ElasticExecutor]]:
    """A raw rclpy node spinning on an ElasticExecutor in a thread (shut down afterwards);
    with ``quick_cooling`` quiet entities move to the cold waiter's thread after 50 ms."""
    context = rclpy.Context()
    rclpy.init(context=context, args=[])
    node = Node("wait_plan_test", context=context)
    executor = ElasticExecutor(context=context, cool_after=request.param)
    executor.add_node(node)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    yield node, executor
    executor.shutdown(timeout_sec=EVENT_TIMEOUT)
    thread.join(EVENT_TIMEOUT)
    node.destroy_node()
    rclpy.try_shutdown(context=context)


def test_the_wait_set_is_built_once_and_a_callback_costs_one_wait(
    spun: tuple[Node, ElasticExecutor],
) -> None:
    node, executor = spun
    ticks = [0]
    first: dict[str, int] = {}
    enough = threading.Event()

    def tick() -> None:
        ticks[0] += 1
        if ticks[0] == 1:
            first.update(executor.wait_counts())
        elif ticks[0] >= 41:
            enough.set()

    for index in range(20):
        # Idle entities the wait set carries on each wake-up.
        node.create_subscription(String, f"idle_{index}", lambda _msg: None, 10)
    node.create_timer(0.005, tick)
    assert enough.wait(EVENT_TIMEOUT)
    waits = executor.wait_counts()
    ticked = ticks[0] - 1
    # From the first tick on the entities stay: no new plan. rclpy builds a wait set per
    # wake-up and wakes twice per callback (its handler triggers the executor's guard
    # condition); a hand-off to a helper thread may add a wake-up now and then.
    assert waits["plans"] == first["plans"]
    assert waits["waits"] - first["waits"] <= ticked * 1.5 + 5


def test_a_destroyed_subscription_is_let_go_while_spinning(
    spun: tuple[Node, ElasticExecutor],
) -> None:
    node, _executor = spun
    received = threading.Event()
    later = threading.Event()
    sub = node.create_subscription(String, "plan_topic", lambda _msg: received.set(), 10)
    pub = node.create_publisher(String, "plan_topic", 10)
    assert repeat_until(received, lambda: pub.publish(String(data="a")))
    handle = sub.handle
    node.destroy_subscription(sub)

    def destroyed() -> bool:
        try:
            with handle:
                return False
        except InvalidHandle:
            return True

    # The wake-up the node sends its executor makes the plan let go of the handle.
    for _ in range(int(EVENT_TIMEOUT / 0.05)):
        if destroyed():
            break
        later.wait(0.05)
    assert destroyed()
    # The executor keeps serving the node's other entities.
    again = threading.Event()
    node.create_subscription(String, "plan_topic_2", lambda _msg: again.set(), 10)
    pub_2 = node.create_publisher(String, "plan_topic_2", 10)
    assert repeat_until(again, lambda: pub_2.publish(String(data="b")))


def test_a_qos_event_reaches_its_callback_on_the_elastic_executor(
    spun: tuple[Node, ElasticExecutor],
) -> None:
    node, _executor = spun
    incompatible = threading.Event()
    seen: list[Any] = []

    def on_incompatible(event: Any) -> None:
        seen.append(event)
        incompatible.set()

    node.create_subscription(
        String,
        "qos_topic",
        lambda _msg: None,
        QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE),
        event_callbacks=SubscriptionEventCallbacks(incompatible_qos=on_incompatible),
    )
    node.create_publisher(
        String, "qos_topic", QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    )
    assert incompatible.wait(EVENT_TIMEOUT)
    assert seen[0].total_count >= 1


def _until(predicate: Any) -> bool:
    """Poll ``predicate`` (state the executor's threads change) up to EVENT_TIMEOUT."""
    pause = threading.Event()
    for _ in range(int(EVENT_TIMEOUT / 0.01)):
        if predicate():
            return True
        pause.wait(0.01)
    return bool(predicate())


@pytest.mark.parametrize("spun", [0.05], indirect=True, ids=["quick_cooling"])
def test_quiet_entities_wait_on_the_cold_thread_and_still_get_their_work(
    spun: tuple[Node, ElasticExecutor],
) -> None:
    node, executor = spun
    received: list[str] = []
    arrived = threading.Semaphore(0)
    group = MutuallyExclusiveCallbackGroup()

    def on_message(msg: String) -> None:
        received.append(msg.data)
        arrived.release()

    sub = node.create_subscription(String, "cold_topic", on_message, 10, callback_group=group)
    pub = node.create_publisher(String, "cold_topic", 10)
    assert _until(lambda: pub.get_subscription_count() == 1)
    for index in range(5):
        # The subscription (and everything else but timers) went quiet: the cold thread has it.
        assert _until(lambda: executor.is_cold(sub))
        wakes = executor.wait_counts()["cold_wakes"]
        pub.publish(String(data=str(index)))
        assert arrived.acquire(timeout=EVENT_TIMEOUT)
        assert executor.wait_counts()["cold_wakes"] > wakes
    assert received == ["0", "1", "2", "3", "4"]


@pytest.mark.parametrize("spun", [0.05], indirect=True, ids=["quick_cooling"])
def test_a_quiet_service_and_client_answer_from_the_cold_thread(
    spun: tuple[Node, ElasticExecutor],
) -> None:
    node, executor = spun

    def answer(_request: Any, response: Any) -> Any:
        response.success = True
        response.message = "cold"
        return response

    service = node.create_service(Trigger, "cold_service", answer)
    client = node.create_client(Trigger, "cold_service")
    assert client.wait_for_service(timeout_sec=EVENT_TIMEOUT)
    for _ in range(3):
        assert _until(lambda: executor.is_cold(service) and executor.is_cold(client))
        done = threading.Event()
        future = client.call_async(Trigger.Request())
        future.add_done_callback(lambda _future, done=done: done.set())
        assert done.wait(EVENT_TIMEOUT)
        assert future.result().message == "cold"
