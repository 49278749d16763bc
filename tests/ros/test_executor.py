"""The agents' executor: EventsExecutor inline, elastic when a callback blocks; order kept."""

from __future__ import annotations

import gc
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import rclpy
import rclpy.task
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from std_msgs.msg import String
from std_srvs.srv import Trigger
from test_msgs.action import Fibonacci

from pyconnect.ros import callback_watch
from pyconnect.ros.executor import ElasticExecutor

from .conftest import EVENT_TIMEOUT, repeat_until
from .test_shutdown import run_child


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


def _wait_for_mode(node: Any, mode: str) -> bool:
    reached = threading.Event()
    for _ in range(int(EVENT_TIMEOUT / 0.05)):
        if node._executor.mode == mode:
            reached.set()
            break
        reached.wait(0.05)
    return reached.is_set()


def test_quick_callbacks_run_on_events_executor_and_a_blocking_one_moves_and_returns(
    make_node: Any,
) -> None:
    node = make_node()
    node.add_agent(
        conn_name="lookup",
        conn_type="service_server",
        data_interface=Trigger,
        response_func=lambda _request: {"success": True, "message": "ok"},
    )
    client = node.add_agent(
        conn_name="lookup",
        agent_name="lookup_client",
        conn_type="service_client",
        data_interface=Trigger,
    )
    answered = threading.Event()
    seen: list[str] = []

    def on_command(value: str) -> None:
        seen.append(value)
        if value == "block":
            client.send({}, timeout=EVENT_TIMEOUT)
            answered.set()

    node.add_agent(
        conn_name="command", conn_type="sub", data_interface=String, response_func=on_command
    )
    pub = node.add_agent(
        conn_name="command", agent_name="out", conn_type="pub", data_interface=String
    )
    node.spin(run_thread=True)
    assert node._executor.mode == "events"
    got_quick = threading.Event()
    assert repeat_until(got_quick, lambda: (pub.send("quick"), seen and got_quick.set()))
    assert repeat_until(answered, lambda: pub.send("block"))
    assert node._executor.handoffs >= 1
    # Calm again: back on EventsExecutor, and messages still arrive there.
    assert _wait_for_mode(node, "events")
    count = len(seen)
    later = threading.Event()
    assert repeat_until(later, lambda: (pub.send("after"), len(seen) > count and later.set()))


def _wait_for_handoffs(node: Any, count: int, seconds: float) -> bool:
    reached = threading.Event()
    for _ in range(int(seconds / 0.05)):
        if node._executor.handoffs >= count:
            reached.set()
            break
        reached.wait(0.05)
    return reached.is_set()


def test_a_slow_callback_right_after_the_move_back_moves_the_node_again(
    make_node: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The watch sleeps while the node is elastic (1 s at a time; 20 s here). Unless the move
    # back wakes it, a slow callback on the new EventsExecutor stops every agent until then.
    monkeypatch.setattr(callback_watch, "IDLE_TICK", 5.0)
    node = make_node()
    first_started, second_started = threading.Event(), threading.Event()
    release = threading.Event()

    def on_work(value: str) -> None:
        if value == "first":
            first_started.set()
        elif value == "second":
            second_started.set()
        release.wait(EVENT_TIMEOUT)

    node.add_agent(conn_name="work", conn_type="sub", data_interface=String, response_func=on_work)
    pub = node.add_agent(
        conn_name="work", agent_name="work_out", conn_type="pub", data_interface=String
    )
    node.spin(run_thread=True)
    try:
        assert repeat_until(first_started, lambda: pub.send("first"))
        assert _wait_for_handoffs(node, 1, EVENT_TIMEOUT)
        release.set()
        assert _wait_for_mode(node, "events")
        release.clear()
        pub.send("second")
        assert second_started.wait(EVENT_TIMEOUT)
        # Noticed after 20-120 ms when the watch is awake; it would sleep on for ~18 s.
        assert _wait_for_handoffs(node, 2, 5.0), "the slow callback went unnoticed"
    finally:
        release.set()


@pytest.fixture
def elastic_node() -> Iterator[tuple[Node, ElasticExecutor, list[float]]]:
    """A raw rclpy node on an ElasticExecutor (handoff_after 20 ms) not spinning yet, and the
    times its monitor thread looks at the turn (it takes the turn's lock to look)."""
    context = rclpy.Context()
    rclpy.init(context=context, args=[])
    node = Node("elastic_monitor_test", context=context)
    executor = ElasticExecutor(context=context, handoff_after=0.02)
    looks: list[float] = []

    class SeenTurn(threading.Condition):
        def __enter__(self) -> bool:
            if threading.current_thread().name == "pyconnect-executor-monitor":
                looks.append(time.monotonic())
            return super().__enter__()

    executor._turn = SeenTurn()
    executor.add_node(node)
    yield node, executor, looks
    executor.shutdown(timeout_sec=EVENT_TIMEOUT)
    node.destroy_node()
    rclpy.try_shutdown(context=context)


def _spin_until_quiet(node: Node, executor: ElasticExecutor) -> None:
    """Spin ``executor`` in a thread, run one quick callback, then leave the node idle."""
    ran = threading.Event()
    quick = node.create_guard_condition(ran.set, MutuallyExclusiveCallbackGroup())
    threading.Thread(target=executor.spin, daemon=True).start()
    quick.trigger()
    assert ran.wait(EVENT_TIMEOUT)
    # Nothing can end this wait: the monitor settles into its idle way of looking.
    threading.Event().wait(0.5)


def test_the_elastic_monitor_does_not_wake_while_the_node_is_idle(
    elastic_node: tuple[Node, ElasticExecutor, list[float]],
) -> None:
    node, executor, looks = elastic_node
    _spin_until_quiet(node, executor)
    count = len(looks)
    threading.Event().wait(1.0)
    assert len(looks) == count, "the monitor woke while no callback ran"


def test_the_elastic_monitor_hands_off_a_callback_that_starts_while_it_idles(
    elastic_node: tuple[Node, ElasticExecutor, list[float]],
) -> None:
    # Right after a look of an idle monitor, a long callback starts: the other callbacks must
    # get a turn within ~handoff_after, not at the next of the idle looks 0.25 s apart.
    node, executor, looks = elastic_node
    release, slow_started, quick_ran = threading.Event(), threading.Event(), threading.Event()
    ran_at: list[float] = []

    def slow() -> None:
        slow_started.set()
        release.wait(EVENT_TIMEOUT)

    def quick() -> None:
        ran_at.append(time.monotonic())
        quick_ran.set()

    slow_guard = node.create_guard_condition(slow, MutuallyExclusiveCallbackGroup())
    quick_guard = node.create_guard_condition(quick, MutuallyExclusiveCallbackGroup())
    _spin_until_quiet(node, executor)
    try:
        count = len(looks)
        aligned = threading.Event()
        for _ in range(50):  # a monitor that looks while idle does so within 0.5 s
            if len(looks) > count:
                aligned.set()
                break
            aligned.wait(0.01)
        start = looks[-1] if aligned.is_set() else time.monotonic()
        slow_guard.trigger()
        assert slow_started.wait(EVENT_TIMEOUT)
        quick_guard.trigger()
        assert quick_ran.wait(EVENT_TIMEOUT)
        assert ran_at[0] - start < 0.2, f"handed off after {ran_at[0] - start:.3f} s"
    finally:
        release.set()


def test_a_node_with_an_action_agent_uses_the_elastic_executor(make_node: Any) -> None:
    from test_msgs.action import Fibonacci

    node = make_node()
    assert node._executor.mode == "events"
    node.add_agent(
        conn_name="fib",
        conn_type="action_server",
        data_interface=Fibonacci,
        response_func=lambda _goal: {"sequence": [1]},
    )
    assert node._executor.mode == "elastic"
    client = node.add_agent(
        conn_name="fib",
        agent_name="fib_client",
        conn_type="action_client",
        data_interface=Fibonacci,
        timeout=EVENT_TIMEOUT,
    )
    node.spin(run_thread=True)
    assert client.send({"order": 1}) == {"sequence": [1], "isdone": True}


def test_a_blocked_agent_stays_exclusive_while_other_agents_run_after_the_move(
    make_node: Any,
) -> None:
    # The move holds the blocked agent's group; a timer agent's callbacks, finishing on the
    # elastic executor meanwhile, must not end that hold (the agent's next message would run
    # beside the first, out of order).
    from std_msgs.msg import Int32

    node = make_node()
    first_started = threading.Event()
    release_first = threading.Event()
    second_started = threading.Event()
    order: list[int] = []
    all_handled = threading.Event()

    def on_int(value: int) -> None:
        if value == 0:
            first_started.set()
            release_first.wait(EVENT_TIMEOUT)
        elif not release_first.is_set():
            second_started.set()
        order.append(value)
        if value == 5:
            all_handled.set()

    ticks_on_elastic: list[int] = []
    ticked = threading.Event()

    def on_tick() -> None:
        if node._executor.mode == "elastic" and first_started.is_set():
            ticks_on_elastic.append(1)
            if len(ticks_on_elastic) >= 3:
                ticked.set()

    node.add_agent(conn_name="ints", conn_type="sub", data_interface=Int32, response_func=on_int)
    node.add_agent(conn_name="tick", conn_type="timer", time_period=0.02, response_func=on_tick)
    pub = node.add_agent(conn_name="ints", agent_name="out", conn_type="pub", data_interface=Int32)
    node.spin(run_thread=True)
    assert repeat_until(first_started, lambda: pub.send(0))
    assert _wait_for_mode(node, "elastic")
    for value in range(1, 6):
        pub.send(value)
    assert ticked.wait(EVENT_TIMEOUT)  # the timer's callbacks have ended on the elastic executor
    # Nothing can wake this wait in a correct run: it only gives a broken hold time to show.
    assert not second_started.wait(1.0), "a second message ran while the first was running"
    release_first.set()
    assert all_handled.wait(EVENT_TIMEOUT)
    # repeat_until may have sent 0 more than once until discovery was done
    assert order[0] == 0 and [value for value in order if value] == [1, 2, 3, 4, 5]


def test_a_hold_taken_as_the_agent_returns_is_ended_when_another_agent_runs_by_then(
    make_node: Any,
) -> None:
    # The monitor holds the group of the agent it saw running; if that agent returned meanwhile
    # and another agent's callback runs by the time the hold is taken, nobody else would end it
    # (only the held agent's own return does): the first agent would never run again.
    staged = 0
    for _attempt in range(5):
        outcome = _stage_a_late_hold(make_node)
        if outcome is None:
            continue  # the node had moved before A ran (a loaded machine): stage it again
        staged += 1
        assert outcome == [], f"agent A stopped after {outcome}"
    assert staged, "the monitor never took the hold while A returned"


def _stage_a_late_hold(make_node: Any) -> list[str] | None:
    """[] when agent A goes on after the staged race; what A got when it stopped; None when
    the race could not be staged (the node was already elastic when A's slow callback ran)."""
    node = make_node(handoff_after=0.1)
    monitor_holding = threading.Event()
    b_started = threading.Event()
    a_seen: list[str] = []
    a_done = threading.Event()
    missed = threading.Event()

    def on_a(value: str) -> None:
        a_seen.append(value)
        if value == "slow":
            if node._executor.mode != "events":
                missed.set()
                b_started.set()
                return
            monitor_holding.wait(EVENT_TIMEOUT)  # returns while the monitor takes the hold
        if value == "a4":
            a_done.set()

    def on_b(_value: str) -> None:
        b_started.set()
        for _ in range(int(EVENT_TIMEOUT / 0.01)):  # running until the move is complete
            if node._executor.handoffs or missed.is_set():
                break
            a_done.wait(0.01)

    sub_a = node.add_agent(
        conn_name="ra", conn_type="sub", data_interface=String, response_func=on_a
    )
    node.add_agent(conn_name="rb", conn_type="sub", data_interface=String, response_func=on_b)
    pub_a = node.add_agent(conn_name="ra", agent_name="pa", conn_type="pub", data_interface=String)
    pub_b = node.add_agent(conn_name="rb", agent_name="pb", conn_type="pub", data_interface=String)
    group = sub_a.callback_group
    begin = group.beginning_execution

    def begin_once_b_runs(entity: Any) -> bool:
        if threading.current_thread().name == "pyconnect-executor-monitor":
            monitor_holding.set()
            b_started.wait(EVENT_TIMEOUT)  # A has returned and B runs
        return bool(begin(entity))

    group.beginning_execution = begin_once_b_runs  # type: ignore[method-assign]
    node.spin(run_thread=True)
    matched = threading.Event()
    assert repeat_until(
        matched, lambda: matched.set() if pub_a.subscriber_count and pub_b.subscriber_count else None
    )
    pub_a.send("slow")
    pub_b.send("b1")
    assert b_started.wait(EVENT_TIMEOUT)
    if missed.is_set():
        node.shutdown()
        return None
    for value in range(5):
        pub_a.send(f"a{value}")
    went_on = a_done.wait(EVENT_TIMEOUT)
    node.shutdown()
    return [] if went_on else a_seen


class _Odd(BaseException):
    """Neither an ``Exception`` nor a request to exit: reported, and the executor goes on."""


def _raise_on_the_node(node: Any, where: str, error: BaseException, ticked: Any) -> None:
    """Raise ``error`` in the first tick of a timer: an agent's (wrapped by the executor) or
    one made with rclpy's own call while the node spins (not wrapped: the dispatching loop
    sees what it raises); ``ticked`` runs on every tick."""
    ticks: list[int] = []

    def tick() -> None:
        ticks.append(1)
        ticked()
        if len(ticks) == 1:
            raise error

    if where == "agent timer":
        node.add_agent(conn_name="ticker", conn_type="timer", time_period=0.01, response_func=tick)
        node.spin(run_thread=True)
    else:
        node.spin(run_thread=True)
        # Once the dispatching loop runs, it has wrapped what there was: not this timer.
        looping = threading.Event()
        assert repeat_until(looping, lambda: node._executor._returns and looping.set())
        timer = node.create_timer(0.01, tick)
        assert not getattr(timer.callback, "_pyconnect_wrapped", False)


@pytest.mark.parametrize("exiting", [SystemExit("the task is done"), KeyboardInterrupt("stop")])
@pytest.mark.parametrize("where", ["agent timer", "rclpy timer", "agent timer, elastic"])
def test_sys_exit_in_a_callback_shuts_the_node_down(
    make_node: Any, monkeypatch: Any, where: str, exiting: BaseException
) -> None:
    """What a user means by sys.exit() in a handler: the node shuts down and a blocking spin()
    returns (before, the dispatching thread died unseen and spin() hung)."""
    node = make_node()
    errors: list[str] = []
    monkeypatch.setattr(node, "_log_error", errors.append)
    if where.endswith("elastic"):  # an action agent keeps the node on the elastic executor
        node.add_agent(
            conn_name="fib",
            conn_type="action_server",
            data_interface=Fibonacci,
            response_func=lambda _goal: {"sequence": [1]},
        )
        assert node._executor.mode == "elastic"
    _raise_on_the_node(node, where.removesuffix(", elastic"), exiting, lambda: None)
    assert node.wait_for_shutdown(EVENT_TIMEOUT)
    assert f"callback raised {type(exiting).__name__}: {exiting}" in errors
    assert not node.ok()


@pytest.mark.parametrize("where", ["agent timer", "rclpy timer"])
def test_another_base_exception_in_a_callback_is_reported_and_the_node_goes_on(
    make_node: Any, monkeypatch: Any, where: str
) -> None:
    node = make_node()
    errors: list[str] = []
    monkeypatch.setattr(node, "_log_error", errors.append)
    count: list[int] = []
    again = threading.Event()

    def ticked() -> None:
        count.append(1)
        if len(count) >= 3:
            again.set()

    _raise_on_the_node(node, where, _Odd("odd"), ticked)
    assert again.wait(EVENT_TIMEOUT)
    assert errors == ["callback raised _Odd: odd"]
    assert node.ok()


CLOSED_STDERR = """
import traceback

closed = sys.stderr is None
try:
    node, heard = make()  # rclpy's EventsExecutor enables faulthandler, which needs a stderr
    node.spin(run_thread=True)
    ready(heard)
    say("stderr is None" if closed else "stderr is open")
    node.get_logger().info("logged with stderr closed")
    node.shutdown()
    print("AFTER CLOSED", flush=True)
except BaseException:
    say("READY")  # the parent reads on: the traceback goes where it can be seen
    traceback.print_exc(file=sys.stdout)
"""


def test_a_node_starts_and_ends_with_stderr_closed(tmp_path: Path) -> None:
    returncode, out, _err = run_child(CLOSED_STDERR, tmp_path, close_stderr=True)
    assert returncode == 0, out
    assert out.splitlines() == ["stderr is None", "STOP", "AFTER CLOSED"], out


def _live_tasks() -> int:
    gc.collect()
    return sum(isinstance(thing, rclpy.task.Task) for thing in gc.get_objects())


@pytest.mark.parametrize("spinning", [False, True])
def test_nodes_created_and_shut_down_leave_no_rclpy_tasks_behind(
    make_node: Any, spinning: bool
) -> None:
    # stop() wakes a dispatcher with a task; one made for an executor nobody spins never ran
    # and stayed alive for ever, twice per node.
    def cycle(index: int) -> None:
        node = make_node(f"cycled_{index}")
        if spinning:
            node.spin(run_thread=True)
        node.shutdown()

    cycle(0)  # whatever the first node creates once for the process
    before = _live_tasks()
    for index in range(1, 51):
        cycle(index)
    assert _live_tasks() - before <= 2
