"""``pyconnect bag play`` (``pyconnect.commands.bag_play``): nothing to play is an error or an
end, never a silent success or a busy loop; what cannot be played right is left out with a
warning; a topic of two types, a damaged bag looped, SIGTERM."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest
import rclpy
from mcap.writer import Writer
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Int32, String
from test_msgs.action import Fibonacci

from pyconnect.cli import main
from pyconnect.record.mcap_recorder import McapRecorder
from pyconnect.typesys.installed_definition_text import installed_definition
from tests.commands.processes import ROOT, WAIT, Lines, spawn


@pytest.fixture(scope="module")
def short_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    bag = tmp_path_factory.mktemp("play") / "short"
    with McapRecorder(bag) as recorder:
        recorder.add_topic("/said", "std_msgs/msg/String")
        for k in range(3):
            data = serialize_message(String(data=f"said {k}"))
            recorder.write("/said", data, log_time_ns=1_000_000_000 + k * 1_000_000)
    return bag


def test_play_of_a_topic_not_in_the_bag_is_an_error(
    short_bag: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # It played nothing and exited 0: a typo looked like a success.
    assert main(["bag", "play", str(short_bag), "--topics", "/said", "/nope", "/nix"]) == 1
    captured = capsys.readouterr()
    assert captured.err == (
        f"pyconnect: error: {short_bag}: no topic /nope, /nix in this bag (topics: /said)\n"
    )
    assert "Playing" not in captured.out


@pytest.mark.parametrize("loop", [[], ["--loop"]])
def test_play_with_nothing_to_play_ends_with_a_warning(short_bag: Path, loop: list[str]) -> None:
    # With --loop it reopened the bag at once, again and again, at 100 % CPU for ever.
    argv = ["bag", "play", str(short_bag), *loop, "--start-offset", "100"]
    done = subprocess.run(
        [sys.executable, "-m", "pyconnect.cli", *argv],
        check=False,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=WAIT,
    )
    assert (done.returncode, done.stderr) == (
        0,
        f"pyconnect: warning: nothing to play: {short_bag} has no message "
        "from --start-offset 100 s on\n",
    )
    assert done.stdout == f"Playing {short_bag} (1 topic(s))\n"


def _write_mcap(path: Path, messages: Sequence[tuple[str, str, str, bytes]]) -> Path:
    """A bare ``.mcap`` of (topic, type, message encoding, bytes), one channel per topic, type
    and encoding, 10 ms apart: what McapRecorder never writes (two types, json, bad names)."""
    channels: dict[tuple[str, str, str], int] = {}
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        for k, (topic, msg_type, encoding, data) in enumerate(messages):
            key = (topic, msg_type, encoding)
            if key not in channels:
                schema = writer.register_schema(
                    name=msg_type, encoding="ros2msg", data=installed_definition(msg_type).encode()
                )
                channels[key] = writer.register_channel(
                    topic=topic, message_encoding=encoding, schema_id=schema, metadata={}
                )
            time_ns = 1_700_000_000_000_000_000 + k * 10_000_000
            writer.add_message(
                channel_id=channels[key], log_time=time_ns, publish_time=time_ns, data=data
            )
        writer.finish()
    return path


def _said(k: int) -> bytes:
    return bytes(serialize_message(String(data=f"said {k}")))


def test_play_leaves_out_a_topic_not_serialised_as_cdr(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Its JSON went out as CDR bytes: subscribers got garbage or nothing, and no word of it.
    bag = _write_mcap(
        tmp_path / "json.mcap",
        [
            message
            for k in range(3)
            for message in [
                ("/ok", "std_msgs/msg/String", "cdr", _said(k)),
                ("/j", "std_msgs/msg/String", "json", b'{"data": "said"}'),
            ]
        ],
    )
    assert main(["bag", "play", str(bag), "--rate", "1000"]) == 0
    captured = capsys.readouterr()
    assert captured.err == (
        "pyconnect: warning: not playing /j: serialised as json, not cdr (only CDR plays)\n"
    )
    assert captured.out.splitlines()[0] == f"Playing {bag} (1 topic(s))"
    assert captured.out.splitlines()[-1].startswith("Played 3 message(s);")


def test_play_leaves_out_a_topic_whose_name_ros_refuses(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # create_publisher raised: a traceback, and nothing played.
    bag = _write_mcap(
        tmp_path / "badname.mcap",
        [
            message
            for k in range(3)
            for message in [
                ("/ok", "std_msgs/msg/String", "cdr", _said(k)),
                ("/cam-1/info", "std_msgs/msg/String", "cdr", _said(k)),
            ]
        ],
    )
    assert main(["bag", "play", str(bag), "--rate", "1000"]) == 0
    captured = capsys.readouterr()
    assert captured.err == (
        "pyconnect: warning: not playing /cam-1/info: invalid topic name: topic name must not "
        "contain characters other than alphanumerics, '_', '~', '{', or '}'\n"
    )
    assert captured.out.splitlines()[0] == f"Playing {bag} (1 topic(s))"
    assert captured.out.splitlines()[-1].startswith("Played 3 message(s);")


def test_play_publishes_an_actions_feedback_topic(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # bag record records it with this type, which play called not installed (exit 1).
    bag = tmp_path / "action"
    with McapRecorder(bag) as recorder:
        recorder.add_topic("/fib/_action/feedback", "test_msgs/action/Fibonacci_FeedbackMessage")
        for k in range(3):
            feedback = Fibonacci.Impl.FeedbackMessage()
            feedback.feedback.sequence = list(range(k + 1))
            data = serialize_message(feedback)
            recorder.write("/fib/_action/feedback", data, log_time_ns=1_000_000_000 + k)
    assert main(["bag", "play", str(bag), "--rate", "1000"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    assert captured.out.splitlines()[0] == f"Playing {bag} (1 topic(s))"
    assert captured.out.splitlines()[-1].startswith("Played 3 message(s);")


class _Listener:
    """Raw messages of one topic and type, taken by a node in a context of its own (a DDS
    participant takes one type per topic name)."""

    def __init__(self, msg_class: Any, topic: str) -> None:
        self.got: list[Any] = []
        self.context = Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node(f"bag_play_listener_{id(self)}", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        qos = QoSProfile(depth=10_000)  # every message of several passes, none dropped
        # Raw: bytes of another type are taken too (as DDS delivers them), then decoded here.
        self.node.create_subscription(
            msg_class,
            topic,
            lambda data: self.got.append(_value(data, msg_class)),
            qos,
            raw=True,
        )

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        self.context.try_shutdown()


@pytest.fixture
def listen() -> Iterator[Callable[[Any, str], _Listener]]:
    made: list[_Listener] = []

    def make(msg_class: Any, topic: str) -> _Listener:
        made.append(_Listener(msg_class, topic))
        return made[-1]

    try:
        yield make
    finally:
        for listener in made:
            listener.close()


def _value(data: bytes, msg_class: Any) -> Any:
    try:
        return deserialize_message(data, msg_class).data
    except Exception:  # whatever the bytes were, they were not of this type
        return data


def _spin_until(listeners: Sequence[_Listener], done: Callable[[], bool]) -> None:
    deadline = time.monotonic() + WAIT
    while not done():
        assert time.monotonic() < deadline, [len(listener.got) for listener in listeners]
        for listener in listeners:
            listener.executor.spin_once(timeout_sec=0.01)


def test_play_publishes_each_type_of_a_topic_to_its_own_subscribers(
    tmp_path: Path, listen: Callable[[Any, str], _Listener]
) -> None:
    # Every message went out on the first type's publisher: String subscribers got Int32 bytes
    # and Int32 subscribers nothing, exit 0 and no warning.
    strings = [f"said {k}" for k in range(3)]
    numbers = [5, 6, 7]
    bag = _write_mcap(
        tmp_path / "twotypes.mcap",
        [("/mixed", "std_msgs/msg/String", "cdr", _said(k)) for k in range(3)]
        + [
            ("/mixed", "std_msgs/msg/Int32", "cdr", serialize_message(Int32(data=n)))
            for n in numbers
        ],
    )
    said, counted = listen(String, "/mixed"), listen(Int32, "/mixed")
    player = spawn("-m", "pyconnect.cli", "bag", "play", str(bag), "--loop", "--rate", "5")
    lines = Lines(player)
    try:
        lines.wait_for("^Playing .* \\(1 topic\\(s\\)\\)$")
        # More than a pass of each: a second pass too, which a late discovery cannot miss.
        _spin_until(
            [said, counted],
            lambda: (
                (len(said.got) > 3 and len(counted.got) > 3)
                or not set(said.got)
                <= set(strings)  # another type's bytes: failed, no more waiting
                or player.poll() is not None
            ),
        )
    finally:
        err = lines.stop()
    assert (player.returncode, err) == (0, "")
    assert set(said.got) == set(strings)
    assert set(counted.got) == set(numbers)


def _cut_bag(tmp_path: Path) -> Path:
    """A bag cut in its middle: the messages of its first chunks are still read."""
    bag = tmp_path / "cut"
    with McapRecorder(bag, chunk_size=1024) as recorder:
        recorder.add_topic("/tick", "std_msgs/msg/String")
        for k in range(100):
            recorder.write("/tick", _said(k), log_time_ns=1_000_000_000 + k * 10_000_000)
    mcap = next(bag.glob("*.mcap"))
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) // 2])
    return bag


def test_play_loops_a_damaged_bag_with_ignore_damage(
    tmp_path: Path, listen: Callable[[Any, str], _Listener]
) -> None:
    # It played one pass and exited 0: --loop did not loop.
    bag = _cut_bag(tmp_path)
    done = subprocess.run(
        [sys.executable, "-m", "pyconnect.cli", "bag", "play", str(bag), "--rate", "100"],
        check=False,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=WAIT,
    )
    assert done.returncode == 1  # damage without --ignore-damage: an error, even with --loop
    readable = int(re.findall(r"Played (\d+) message", done.stdout)[0])
    assert 0 < readable < 100
    ticks = listen(String, "/tick")
    player = spawn(
        "-m", "pyconnect.cli", "bag", "play", str(bag), "--loop", "--ignore-damage",
        "--rate", "10",
    )  # fmt: skip
    lines = Lines(player)
    try:
        lines.wait_for("^Playing ")
        _spin_until([ticks], lambda: len(ticks.got) > readable or player.poll() is not None)
        assert player.poll() is None  # still playing, a second pass at least
    finally:
        err = lines.stop()
    assert player.returncode == 0
    assert err.count("damaged bag") == 1  # said once, after the first pass
    assert err.startswith(f"pyconnect: {bag}: damaged bag: ")


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_play_stopped_by_a_signal_exits_0_with_its_summary(
    short_bag: Path, listen: Callable[[Any, str], _Listener], signum: int
) -> None:
    # SIGTERM killed it (exit 143, no summary); Ctrl-C exited 0 without the summary line.
    said = listen(String, "/said")
    player = spawn("-m", "pyconnect.cli", "bag", "play", str(short_bag), "--loop", "--rate", "0.5")
    lines = Lines(player)
    try:
        lines.wait_for("^Playing ")
        _spin_until([said], lambda: bool(said.got) or player.poll() is not None)
    finally:
        err = lines.stop(signum)
    assert (player.returncode, err) == (0, "")
    out = list(lines.lines.queue)
    assert out and re.fullmatch(
        r"Played \d+ message\(s\); timing error: mean -?\d+\.\d{3} ms, max -?\d+\.\d{3} ms",
        out[-1],
    ), out


def test_a_stop_right_after_a_publish_counts_that_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A signal's handler raises at the next instruction: right after the first publish, the
    message went out uncounted and the stop printed no summary (a flaky signal test)."""
    from rclpy.publisher import Publisher

    bag = _write_mcap(
        tmp_path / "three.mcap", [("/ok", "std_msgs/msg/String", "cdr", _said(k)) for k in range(3)]
    )
    publish = Publisher.publish

    def publish_then_interrupted(self: Publisher, message: Any) -> None:
        publish(self, message)
        if self.topic_name == "/ok":  # not the session's own publishers
            raise KeyboardInterrupt  # as the SIGTERM/Ctrl-C handler would, just after

    monkeypatch.setattr(Publisher, "publish", publish_then_interrupted)
    assert main(["bag", "play", str(bag), "--rate", "1000"]) == 0
    captured = capsys.readouterr()
    assert captured.out.splitlines()[-1].startswith("Played 1 message(s);"), captured
