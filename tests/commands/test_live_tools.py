"""``pyconnect topic|service|action|node`` against a plain rclpy process (tests/commands/plain_peer)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import SimpleNamespace

import pytest

from pyconnect.cli import main
from pyconnect.commands import graph
from pyconnect.commands.graph import NODE_NAME_UNKNOWN, GraphSession
from tests.commands.processes import WAIT, Lines, spawn


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    status = main(list(argv))
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def _until(
    capsys: pytest.CaptureFixture[str], check: Callable[[str], bool], *argv: str
) -> tuple[int, str]:
    """Run a listing until its output passes ``check`` (discovery takes a while when loaded)."""
    deadline = time.monotonic() + WAIT
    while True:
        status, out, _err = _run(capsys, *argv)
        if check(out) or time.monotonic() > deadline:
            return status, out


def test_topic_list_shows_types(peer: Lines, capsys: pytest.CaptureFixture[str]) -> None:
    status, out = _until(capsys, lambda out: "/image" in out, "topic", "list", "-t")
    assert status == 0
    assert "/chatter [std_msgs/msg/String]" in out.splitlines()
    assert "/image [sensor_msgs/msg/Image]" in out.splitlines()
    status, out = _until(capsys, lambda out: "/image" in out, "topic", "list")
    assert "/chatter" in out.splitlines()


def test_topic_info_counts_and_qos(peer: Lines, capsys: pytest.CaptureFixture[str]) -> None:
    # info spins the whole --spin-time: asked again until discovery has found the peer.
    status, out = _until(
        capsys, lambda out: "Publisher count: 1" in out, "topic", "info", "/chatter"
    )
    assert status == 0
    assert out.splitlines() == [
        "Type: std_msgs/msg/String",
        "Publisher count: 1",
        "Subscription count: 0",
    ]
    status, out = _until(
        capsys, lambda out: "Node name: plain_peer" in out, "topic", "info", "/chatter", "-v"
    )
    assert status == 0
    lines = out.splitlines()
    assert lines[:4] == ["Type: std_msgs/msg/String", "", "Publisher count: 1", ""]
    for expected in (
        "Node name: plain_peer",
        "Node namespace: /",
        "Endpoint type: PUBLISHER",
        "  Reliability: RELIABLE",
        "  History (Depth): UNKNOWN",
        "  Durability: VOLATILE",
        "Subscription count: 0",
    ):
        assert expected in lines


def test_topic_info_of_an_unknown_topic(capsys: pytest.CaptureFixture[str]) -> None:
    assert _run(capsys, "topic", "info", "/nope", "--spin-time", "0.5") == (
        1,
        "",
        "pyconnect: error: Unknown topic '/nope'\n",
    )


def test_topic_echo_natural_values(peer: Lines, capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = _run(capsys, "topic", "echo", "/chatter", "--once", "--timeout", str(WAIT))
    assert status == 0
    assert re.fullmatch(r"'hello \d+'\n---\n", out), out
    status, out, _ = _run(
        capsys, "topic", "echo", "/image", "--once", "--qos-profile", "sensor_data"
    )
    assert (status, out) == (
        0,
        "Image(shape=(2, 2), dtype=uint8, encoding=mono8, mean=15.000)\n---\n",
    )
    status, out, _ = _run(capsys, "topic", "echo", "/image", "--once", "--json")
    assert json.loads(out) == {"shape": [2, 2], "dtype": "uint8", "encoding": "mono8", "mean": 15.0}
    status, out, _ = _run(
        capsys, "topic", "echo", "/image", "--once", "--json", "--field", "header"
    )
    assert json.loads(out) == {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""}
    status, out, _ = _run(
        capsys, "topic", "echo", "/chatter", "--once", "--field", "data", "--json"
    )
    assert re.fullmatch(r'"hello \d+"\n', out), out


def test_topic_echo_errors(peer: Lines, capsys: pytest.CaptureFixture[str]) -> None:
    assert _run(capsys, "topic", "echo", "/nope", "--timeout", "0.5") == (
        1,
        "",
        "pyconnect: error: topic [/nope] does not appear to be published yet; could not "
        "determine its type\n",
    )
    assert _run(capsys, "topic", "echo", "/chatter", "--once", "--field", "nope") == (
        1,
        "",
        "pyconnect: error: --field nope: no field 'nope' in String\n",
    )
    status, _out, err = _run(capsys, "topic", "echo")
    assert (status, err) == (2, "pyconnect: error: the following arguments are required: topic\n")


PROFILES = (
    "'default', 'system_default', 'sensor_data', 'services_default', 'parameters', "
    "'parameter_events', 'action_status_default', 'best_available'"
)


@pytest.mark.parametrize(
    "argv",
    [
        ["topic", "echo", "/chatter"],
        ["topic", "hz", "/chatter"],
        ["topic", "bw", "/chatter"],
        ["topic", "pub", "/x", "std_msgs/msg/String", "hi", "--once", "-w", "0"],
    ],
)
@pytest.mark.parametrize("profile", ["fast", "unknown"])
def test_qos_profile_is_one_of_the_presets(
    argv: list[str], profile: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # "unknown" is a preset of rclpy's that rmw refuses: it was let through, and crashed.
    assert _run(capsys, *argv, "--qos-profile", profile) == (
        2,
        "",
        f"pyconnect: error: argument --qos-profile: invalid choice: '{profile}' "
        f"(choose from {PROFILES})\n",
    )


WHOLE = "expected a whole number >= 1, got "
POSITIVE = "expected a number > 0 and <= 1e+09, got "
SPAN = "expected a number of seconds from 0 to 9.22e+09, got "


@pytest.mark.parametrize(
    ("argv", "error"),
    [
        (["topic", "hz", "/x", "--window", "0"], "argument -w/--window: " + WHOLE + "'0'"),
        (["topic", "bw", "/x", "-w", "0"], "argument -w/--window: " + WHOLE + "'0'"),
        (["topic", "hz", "/x", "-w", "-3"], "argument -w/--window: " + WHOLE + "'-3'"),
        (["topic", "hz", "/x", "-w", "many"], "argument -w/--window: " + WHOLE + "'many'"),
        (
            ["topic", "pub", "/x", "std_msgs/msg/String", "hi", "--rate", "0"],
            "argument -r/--rate: " + POSITIVE + "'0'",
        ),
        (
            ["topic", "pub", "/x", "std_msgs/msg/String", "hi", "-r", "nan"],
            "argument -r/--rate: " + POSITIVE + "'nan'",
        ),
        (["bag", "play", "b.mcap", "-r", "nan"], "argument -r/--rate: " + POSITIVE + "'nan'"),
        (["bag", "play", "b.mcap", "-r", "0"], "argument -r/--rate: " + POSITIVE + "'0'"),
        (["bag", "play", "b.mcap", "-r", "1e308"], "argument -r/--rate: " + POSITIVE + "'1e308'"),
        (
            ["bag", "play", "b.mcap", "--start-offset", "inf"],
            "argument --start-offset: " + SPAN + "'inf'",
        ),
        (
            ["bag", "play", "b.mcap", "--start-offset", "1e300"],
            "argument --start-offset: " + SPAN + "'1e300'",
        ),
        (
            ["bag", "play", "b.mcap", "--start-offset", "nan"],
            "argument --start-offset: " + SPAN + "'nan'",
        ),
        (
            ["bag", "play", "b.mcap", "--start-offset", "-1"],
            "argument --start-offset: " + SPAN + "'-1'",
        ),
        (["bag", "play", "b.mcap", "--delay", "inf"], "argument -d/--delay: " + SPAN + "'inf'"),
    ],
)
def test_bad_option_values_are_a_bad_command_line(
    argv: list[str], error: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _run(capsys, *argv) == (2, "", f"pyconnect: error: {error}\n")


@pytest.mark.parametrize(
    ("verb", "pattern"),
    [
        ("hz", r"^average rate: (\d+\.\d{3})$"),
        ("bw", r"^(\d+(?:\.\d\d)?) (B|KB|MB)/s from (\d+) messages$"),
    ],
)
def test_hz_and_bw_print_ros2cli_lines_until_ctrl_c(peer: Lines, verb: str, pattern: str) -> None:
    process = spawn("-m", "pyconnect.cli", "topic", verb, "/chatter")
    lines = Lines(process)
    try:
        _seen, found = lines.wait_for(pattern)
        assert float(found.group(1)) > 0
        _seen, detail = lines.wait_for(r"^\t(min|Message size mean)")
        if verb == "hz":
            assert re.fullmatch(
                r"\tmin: \d+\.\d{3}s max: \d+\.\d{3}s std dev: \d+\.\d{5}s window: \d+",
                detail.string,
            )
        else:
            assert re.fullmatch(r"\tMessage size mean: \d+ B min: \d+ B max: \d+ B", detail.string)
    finally:
        err = lines.stop()
    assert (process.returncode, err) == (130, "")


def test_topic_pub_reaches_a_plain_subscriber(
    peer: Lines, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, _ = _run(
        capsys,
        "topic",
        "pub",
        "/commands",
        "std_msgs/msg/String",
        "hi there",
        "--once",
        "--timeout",
        str(WAIT),
    )
    assert status == 0
    assert out.splitlines()[-2:] == ["publisher: beginning loop", "publishing #1: 'hi there'"]
    peer.wait_for("^got hi there$")
    status, out, _ = _run(
        capsys,
        "topic",
        "pub",
        "/commands",
        "std_msgs/msg/String",
        "{data: as dict}",
        "-t",
        "2",
        "--rate",
        "20",
        "--timeout",
        str(WAIT),
    )
    assert status == 0
    assert out.splitlines()[-1] == "publishing #2: 'as dict'"
    peer.wait_for("^got as dict$")


def test_topic_pub_bad_values(capsys: pytest.CaptureFixture[str]) -> None:
    assert _run(capsys, "topic", "pub", "/x", "std_msgs/msg/Nope", "1", "--once") == (
        1,
        "",
        "pyconnect: error: std_msgs/msg/Nope: no such interface is installed (module "
        "'std_msgs.msg' has no attribute 'Nope')\n",
    )
    status, _out, err = _run(
        capsys, "topic", "pub", "/x", "geometry_msgs/msg/Twist", "[1, 2", "--once"
    )
    assert status == 1
    assert err.startswith("pyconnect: error: VALUE is not YAML or JSON: ")


def test_service_list_and_call(peer: Lines, capsys: pytest.CaptureFixture[str]) -> None:
    status, out = _until(capsys, lambda out: "/set_flag" in out, "service", "list", "-t")
    assert status == 0
    assert "/set_flag [std_srvs/srv/SetBool]" in out.splitlines()
    status, out, _ = _run(
        capsys,
        "service",
        "call",
        "/set_flag",
        "std_srvs/srv/SetBool",
        "{data: true}",
        "--timeout",
        str(WAIT),
    )
    assert status == 0
    assert out.splitlines()[-5:] == [
        "requester: making request: {'data': True}",
        "",
        "response:",
        "{'success': True, 'message': 'flag is True'}",
        "",
    ]
    assert _run(
        capsys, "service", "call", "/absent", "std_srvs/srv/SetBool", "--timeout", "0.5"
    ) == (
        1,
        "waiting for service to become available...\n",
        "pyconnect: error: service /absent not available\n",
    )


def test_action_list_and_send_goal(peer: Lines, capsys: pytest.CaptureFixture[str]) -> None:
    status, out = _until(capsys, lambda out: "/fibonacci" in out, "action", "list", "-t")
    assert "/fibonacci [test_msgs/action/Fibonacci]" in out.splitlines()
    status, out, _ = _run(
        capsys,
        "action",
        "send_goal",
        "/fibonacci",
        "test_msgs/action/Fibonacci",
        "{order: 4}",
        "--feedback",
        "--timeout",
        str(WAIT),
    )
    assert status == 0
    lines = out.splitlines()
    assert "Sending goal:" in lines
    assert "     {'order': 4}" in lines
    assert "    {'sequence': [0, 1, 1, 2]}" in lines  # a feedback
    assert lines.count("Feedback:") == 3
    assert any(re.fullmatch(r"Goal accepted with ID: [0-9a-f]{32}", line) for line in lines)
    assert lines[-4:] == [
        "Result:",
        "    {'sequence': [0, 1, 1, 2, 3]}",
        "",
        "Goal finished with status: SUCCEEDED",
    ]


def test_node_list_and_info(peer: Lines, capsys: pytest.CaptureFixture[str]) -> None:
    status, out = _until(capsys, lambda out: "/plain_peer" in out, "node", "list")
    assert status == 0
    assert "/plain_peer" in out.splitlines()
    assert not any(line.startswith("/_pyconnect") for line in out.splitlines())
    status, out, _ = _run(capsys, "node", "info", "/plain_peer", "--spin-time", str(WAIT))
    assert status == 0
    lines = out.splitlines()
    assert lines[0] == "/plain_peer"
    for section, entry in (
        ("  Subscribers:", "    /commands: std_msgs/msg/String"),
        ("  Publishers:", "    /chatter: std_msgs/msg/String"),
        ("  Service Servers:", "    /set_flag: std_srvs/srv/SetBool"),
        ("  Action Servers:", "    /fibonacci: test_msgs/action/Fibonacci"),
    ):
        assert section in lines
        assert entry in lines
    assert _run(capsys, "node", "info", "/nobody", "--spin-time", "0.5") == (
        1,
        "",
        "pyconnect: error: Unable to find node '/nobody'\n",
    )


@pytest.mark.parametrize(
    "argv",
    [
        ["topic", "--help"],
        ["topic", "pub", "--help"],
        ["service", "--help"],
        ["action", "--help"],
        ["node", "--help"],
    ],
)
def test_help_has_examples(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = _run(capsys, *argv)
    assert status == 0
    assert "examples:\n  pyconnect " in out


def test_echo_timeout_gives_up_on_a_topic_without_publishers() -> None:
    # A subprocess: before the fix the wait for a first message never ended.
    argv = ["topic", "echo", "/nobody", "std_msgs/msg/String", "--timeout", "0.5"]
    done = subprocess.run(
        [sys.executable, "-m", "pyconnect.cli", *argv],
        check=False,
        capture_output=True,
        text=True,
        timeout=WAIT,
    )
    assert (done.returncode, done.stdout, done.stderr) == (
        1,
        "",
        "pyconnect: error: no message on [/nobody] within 0.5 s: it has no publishers\n",
    )


def test_echo_warns_once_of_publishers_of_another_type(peer: Lines) -> None:
    process = spawn(
        "-m", "pyconnect.cli", "topic", "echo", "/chatter", "std_msgs/msg/Int32", merge_stderr=True
    )
    lines = Lines(process)
    try:
        _seen, found = lines.wait_for("warning")
    finally:
        lines.stop()
    assert found.string == (
        "pyconnect: warning: [/chatter] is published as std_msgs/msg/String, not "
        "std_msgs/msg/Int32: waiting for a publisher of std_msgs/msg/Int32"
    )
    assert process.returncode == 130
    rest = []
    while not lines.lines.empty():
        rest.append(lines.lines.get())
    assert rest == []


@pytest.mark.parametrize(
    ("published", "reason"),
    [
        ([], "no message on [/chatter] within 3 s: it has no publishers"),
        (
            ["std_msgs/msg/String", "std_msgs/msg/String"],
            "no message on [/chatter] within 3 s: it is published as std_msgs/msg/String, not "
            "std_msgs/msg/Int32",
        ),
        (
            ["std_msgs/msg/Int32"],
            "no message on [/chatter] within 3 s from its 1 publisher(s) of std_msgs/msg/Int32",
        ),
        (
            ["std_msgs/msg/String", "std_msgs/msg/Int32"],
            "no message on [/chatter] within 3 s from its 1 publisher(s) of std_msgs/msg/Int32 "
            "(others publish std_msgs/msg/String)",
        ),
    ],
)
def test_echo_timeout_says_why_no_message_came(published: list[str], reason: str) -> None:
    from pyconnect.commands.topic_subscribe import no_message_reason

    assert no_message_reason("/chatter", "std_msgs/msg/Int32", published, 3.0) == reason


class _GraphSoonNamed:
    """A graph whose endpoints are discovered before their node's name, as rmw reports them."""

    def __init__(self) -> None:
        self.spins = 0

    def _named(self) -> bool:
        return self.spins >= 3

    def get_topic_names_and_types(self) -> list[tuple[str, list[str]]]:
        return [("/chatter", ["std_msgs/msg/String"])] if self.spins else []

    def get_publishers_info_by_topic(self, topic: str) -> list[SimpleNamespace]:
        return [SimpleNamespace(node_name="plain_peer" if self._named() else NODE_NAME_UNKNOWN)]

    def get_subscriptions_info_by_topic(self, topic: str) -> list[SimpleNamespace]:
        return []

    def get_node_names_and_namespaces(self) -> list[tuple[str, str]]:
        return [("plain_peer", "/")] if self._named() else []


class _Session:
    spin_until = GraphSession.spin_until

    def __init__(self) -> None:
        self.node = _GraphSoonNamed()

    def spin_once(self, timeout: float = 0.05) -> None:
        self.node.spins += 1

    def spin_for(self, seconds: float) -> None:
        self.spin_once()  # --spin-time ends with the topics seen and their node not yet named


def test_node_list_waits_for_the_nodes_of_the_endpoints_it_sees(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    @contextmanager
    def session(_name: str) -> Iterator[_Session]:
        yield _Session()

    monkeypatch.setattr(graph, "graph_session", session)
    assert _run(capsys, "node", "list", "--spin-time", str(WAIT)) == (0, "/plain_peer\n", "")


class _GraphFoundInStages:
    """A graph discovery finds a stage at a time (one per spin): publishers in other processes
    keep appearing after a topic is first seen. Each stage holds the (node, type) of each
    publisher of /chatter."""

    def __init__(self, stages: list[list[tuple[str, str]]]) -> None:
        self.stages = stages
        self.spins = 0

    def _publishers(self) -> list[tuple[str, str]]:
        return self.stages[min(self.spins, len(self.stages) - 1)]

    def get_topic_names_and_types(self) -> list[tuple[str, list[str]]]:
        types = sorted({msg_type for _node, msg_type in self._publishers()})
        return [("/chatter", types)] if types else []

    def get_publishers_info_by_topic(self, topic: str) -> list[SimpleNamespace]:
        return [
            SimpleNamespace(node_name=node, topic_type=msg_type, qos_profile=SimpleNamespace())
            for node, msg_type in (self._publishers() if topic == "/chatter" else [])
        ]

    def get_subscriptions_info_by_topic(self, topic: str) -> list[SimpleNamespace]:
        return []

    def create_subscription(self, *_args: object, **_kwargs: object) -> None:
        raise AssertionError("subscribed to a topic of more than one type")


class _StagedSession:
    spin_until = GraphSession.spin_until

    def __init__(self, graph: _GraphFoundInStages) -> None:
        self.node = graph

    def spin_once(self, timeout: float = 0.05) -> None:
        self.node.spins += 1

    def spin_for(self, seconds: float) -> None:
        self.node.spins = len(self.node.stages)  # --spin-time is long enough to find them all


def _staged_graph(monkeypatch: pytest.MonkeyPatch, stages: list[list[tuple[str, str]]]) -> None:
    @contextmanager
    def session(_name: str) -> Iterator[_StagedSession]:
        yield _StagedSession(_GraphFoundInStages(stages))

    monkeypatch.setattr(graph, "graph_session", session)


STRING = "std_msgs/msg/String"
FLOAT = "std_msgs/msg/Float64"


def test_topic_info_counts_what_discovery_finds_in_the_spin_time(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    first = [("pub_0", STRING)]
    _staged_graph(monkeypatch, [[], first, [*first, ("pub_1", STRING), ("pub_2", STRING)]])
    assert _run(capsys, "topic", "info", "/chatter", "--spin-time", str(WAIT)) == (
        0,
        f"Type: {STRING}\nPublisher count: 3\nSubscription count: 0\n",
        "",
    )


def test_topic_info_lists_every_type_of_a_topic(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _staged_graph(monkeypatch, [[], [("pub_0", STRING)], [("pub_0", STRING), ("pub_1", FLOAT)]])
    assert _run(capsys, "topic", "info", "/chatter") == (
        0,
        f"Type: ['{FLOAT}', '{STRING}']\nPublisher count: 2\nSubscription count: 0\n",
        "",
    )


@pytest.mark.parametrize(
    ("verb", "doing"),
    [("echo", "echo"), ("hz", "measure the rate of"), ("bw", "measure the bandwidth of")],
)
def test_a_topic_of_two_types_needs_the_type_given(
    verb: str, doing: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _staged_graph(monkeypatch, [[], [("pub_0", STRING), ("pub_1", FLOAT)]])
    assert _run(capsys, "topic", verb, "/chatter") == (
        1,
        "",
        f"pyconnect: error: cannot {doing} /chatter: it has more than one type ({FLOAT}, "
        f"{STRING}); give the type\n",
    )


@pytest.mark.parametrize(
    ("verb", "doing"),
    [("echo", "echo"), ("hz", "measure the rate of"), ("bw", "measure the bandwidth of")],
)
def test_a_second_type_discovered_a_moment_later_still_needs_the_type_given(
    verb: str, doing: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # Another process's publisher is found a few spins after the first: the types read at the
    # first sight of the topic were one process's, and the verb subscribed to that one.
    first = [("pub_0", STRING)]
    _staged_graph(monkeypatch, [[], first, first, first, [*first, ("pub_1", FLOAT)]])
    assert _run(capsys, "topic", verb, "/chatter") == (
        1,
        "",
        f"pyconnect: error: cannot {doing} /chatter: it has more than one type ({FLOAT}, "
        f"{STRING}); give the type\n",
    )


class _Subscribed(Exception):
    """Raised by a fake node's create_subscription: the command went as far as subscribing."""


class _GraphOfQoS(_GraphFoundInStages):
    """Publishers of /chatter found a stage per spin; each stage holds (node, reliability)."""

    def __init__(self, stages: list[list[tuple[str, str]]]) -> None:
        super().__init__([[(node, STRING) for node, _ in stage] for stage in stages])
        self.reliabilities = stages
        self.qos: list[object] = []

    def get_publishers_info_by_topic(self, topic: str) -> list[SimpleNamespace]:
        from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

        stage = self.reliabilities[min(self.spins, len(self.reliabilities) - 1)]
        return [
            SimpleNamespace(
                node_name=node,
                topic_type=STRING,
                qos_profile=SimpleNamespace(
                    reliability=ReliabilityPolicy.get_from_short_key(reliability),
                    durability=DurabilityPolicy.VOLATILE,
                ),
            )
            for node, reliability in (stage if topic == "/chatter" else [])
        ]

    def get_logger(self) -> SimpleNamespace:
        return SimpleNamespace(set_level=lambda _level: None)

    def create_subscription(self, *args: object, **kwargs: object) -> None:
        self.qos.append(args[3])
        raise _Subscribed


def test_echo_matches_the_qos_of_publishers_discovered_a_moment_later(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from rclpy.qos import ReliabilityPolicy

    first = [("pub_0", "reliable")]
    found = _GraphOfQoS([[], first, first, first, [*first, ("pub_1", "best_effort")]])

    @contextmanager
    def session(_name: str) -> Iterator[_StagedSession]:
        yield _StagedSession(found)

    monkeypatch.setattr(graph, "graph_session", session)
    with pytest.raises(_Subscribed):
        main(["topic", "echo", "/chatter", STRING])
    # Reliable, chosen at the first sight of pub_0, never hears the best-effort pub_1.
    assert [qos.reliability for qos in found.qos] == [ReliabilityPolicy.BEST_EFFORT]  # type: ignore[attr-defined]


class _GraphOfOneType(_GraphFoundInStages):
    """/chatter published as String; a subscription of another type never hears it."""

    def __init__(self) -> None:
        super().__init__([[("pub_0", STRING)]])

    def create_subscription(self, *_args: object, **_kwargs: object) -> None:
        return None

    def get_clock(self) -> None:
        return None


class _SpinCountingSession(_StagedSession):
    def spin_once(self, timeout: float = 0.05) -> None:
        super().spin_once(timeout)
        if self.node.spins > 10_000:
            raise AssertionError("still spinning long after --timeout")


@pytest.mark.parametrize(("verb", "out"), [("hz", ""), ("bw", "Subscribed to [/chatter]\n")])
def test_hz_and_bw_give_up_on_a_topic_of_another_type_at_the_timeout(
    verb: str, out: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    @contextmanager
    def session(_name: str) -> Iterator[_StagedSession]:
        yield _SpinCountingSession(_GraphOfOneType())

    monkeypatch.setattr(graph, "graph_session", session)
    argv = ["topic", verb, "/chatter", "std_msgs/msg/Int32", "--timeout", "0"]
    assert _run(capsys, *argv) == (
        1,
        out,
        "pyconnect: error: no message on [/chatter] within 0 s: it is published as "
        "std_msgs/msg/String, not std_msgs/msg/Int32\n",
    )


@pytest.mark.parametrize("verb", ["hz", "bw"])
def test_hz_and_bw_warn_once_of_publishers_of_another_type(peer: Lines, verb: str) -> None:
    process = spawn(
        "-m", "pyconnect.cli", "topic", verb, "/chatter", "std_msgs/msg/Int32", merge_stderr=True
    )
    lines = Lines(process)
    try:
        _seen, found = lines.wait_for("warning")
    finally:
        lines.stop()
    assert found.string == (
        "pyconnect: warning: [/chatter] is published as std_msgs/msg/String, not "
        "std_msgs/msg/Int32: waiting for a publisher of std_msgs/msg/Int32"
    )
    assert process.returncode == 130


def test_send_goal_cancels_the_goal_it_gives_up_on() -> None:
    server = Lines(spawn("-m", "tests.commands.cancel_peer"))
    try:
        server.wait_for("^ready$")
        argv = ["action", "send_goal", "/endless", "test_msgs/action/Fibonacci", "{order: 1}"]
        deadline = time.monotonic() + WAIT
        while True:
            # --timeout bounds finding the server too: tried again while discovery is slow.
            done = subprocess.run(
                [sys.executable, "-m", "pyconnect.cli", *argv, "--timeout", "2"],
                check=False,
                capture_output=True,
                text=True,
                timeout=WAIT,
            )
            if "Goal accepted" in done.stdout or time.monotonic() > deadline:
                break
        assert (done.returncode, done.stderr) == (
            1,
            "pyconnect: error: no result within 2 s: the goal was cancelled\n",
        )
        server.wait_for("^executing$")
        server.wait_for("^canceled$")  # before the fix the goal ran on
    finally:
        server.stop()


def test_topic_and_service_type(peer: Lines, capsys: pytest.CaptureFixture[str]) -> None:
    status, out = _until(capsys, bool, "topic", "type", "/chatter")
    assert (status, out) == (0, "std_msgs/msg/String\n")
    status, out = _until(capsys, bool, "service", "type", "/set_flag")
    assert (status, out) == (0, "std_srvs/srv/SetBool\n")
    assert _run(capsys, "topic", "type", "/nope", "--spin-time", "0.5") == (
        1,
        "",
        "pyconnect: error: Unknown topic '/nope'\n",
    )
    assert _run(capsys, "service", "type", "/nope", "--spin-time", "0.5", "--no-daemon") == (
        1,
        "",
        "pyconnect: error: Unknown service '/nope'\n",
    )


def test_action_info(peer: Lines, capsys: pytest.CaptureFixture[str]) -> None:
    status, out = _until(
        capsys, lambda out: "Action servers: 1" in out, "action", "info", "/fibonacci", "-t"
    )
    assert (status, out.splitlines()) == (
        0,
        [
            "Action: /fibonacci",
            "Action clients: 0",
            "Action servers: 1",
            "    /plain_peer [test_msgs/action/Fibonacci]",
        ],
    )
    status, out = _until(
        capsys, lambda out: "Action servers: 1" in out, "action", "info", "/fibonacci", "-c"
    )
    assert (status, out) == (0, "Action: /fibonacci\nAction clients: 0\nAction servers: 1\n")


def test_service_call_at_a_rate_until_ctrl_c(peer: Lines) -> None:
    argv = ["service", "call", "/set_flag", "std_srvs/srv/SetBool", "{data: true}", "-r", "20"]
    process = spawn("-m", "pyconnect.cli", *argv)
    lines = Lines(process)
    try:
        for _ in range(3):
            lines.wait_for(r"^\{'success': True, 'message': 'flag is True'\}$")
    finally:
        err = lines.stop()
    assert (process.returncode, err) == (130, "")


@pytest.mark.parametrize(
    "argv",
    [
        ["topic", "list"],
        ["topic", "info", "/nope"],
        ["node", "list"],
        ["node", "info", "/nobody"],
        ["service", "list"],
        ["action", "list"],
    ],
)
def test_no_daemon_is_taken_and_ignored(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    # ros2 scripts pass it; pyconnect never has a daemon. (Refused before: exit status 2.)
    status, _out, err = _run(capsys, *argv, "--no-daemon", "--spin-time", "0")
    assert status in (0, 1)
    assert "unrecognized arguments" not in err
