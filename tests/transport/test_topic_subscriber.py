"""A peer sub's ``dropped_count`` from rmw_zenoh attachments: real gaps only, whatever arrives."""

from __future__ import annotations

import collections
import logging
import time
from types import SimpleNamespace
from typing import Any

import pytest
import zenoh

from pyconnect.codecs import wire
from pyconnect.errors import PyconnectError
from pyconnect.transport import topic_subscriber
from tests.transport.conftest import PeerFactory, wait_for, zenoh_attachment

GID_A, GID_B = b"A" * 16, b"B" * 16
HELLO = wire.encode("hello", "std_msgs/msg/String")


def sample(attachment: bytes | None) -> Any:
    """What ``_on_sample`` reads of a zenoh sample: its payload and attachment."""
    return SimpleNamespace(
        payload=zenoh.ZBytes(HELLO),
        attachment=None if attachment is None else zenoh.ZBytes(attachment),
    )


def attached(sequence: int, gid: bytes = GID_A) -> Any:
    return sample(zenoh_attachment(sequence, time.time_ns(), gid))


def handled(sub: Any, *samples: Any) -> int:
    """``sub``'s ``dropped_count`` after it handled ``samples`` (all decoded and counted)."""
    before = sub.message_count
    for each in samples:
        sub._on_sample(each)
    assert sub.message_count == before + len(samples)
    count: int = sub.dropped_count
    return count


@pytest.fixture
def sub(make_peer: PeerFactory) -> Any:
    return make_peer("listener").add_agent(
        conn_name="chat", conn_type="sub", data_interface="std_msgs/msg/String"
    )


def test_gaps_are_counted_per_publisher(sub: Any) -> None:
    assert handled(sub, attached(1), attached(2), attached(5), attached(7, GID_B)) == 2
    assert handled(sub, attached(9, GID_B), attached(6)) == 3


def test_one_bogus_sequence_number_counts_nothing(sub: Any) -> None:
    assert handled(sub, *(attached(n) for n in (1, 2, 2**62, 3, 4))) == 0
    assert handled(sub, attached(6)) == 1


def test_a_sequence_that_goes_back_and_then_forward_is_not_counted_again(sub: Any) -> None:
    assert handled(sub, *(attached(n) for n in (1, 2, 3, 4, 5, 2, 6))) == 0
    assert handled(sub, attached(-7), attached(7), attached(0), attached(9)) == 1


def test_a_restarted_publisher_is_counted_from_its_new_start(sub: Any) -> None:
    assert handled(sub, *(attached(n) for n in (*range(1, 11), 1, 2, 3, 6))) == 2
    assert handled(sub, *(attached(n) for n in range(7, 14)), attached(15)) == 3


def test_a_jump_beyond_the_bound_is_not_a_gap(sub: Any) -> None:
    bound = topic_subscriber.MAX_SEQUENCE_GAP
    assert handled(sub, attached(1), attached(2 + bound)) == bound
    assert handled(sub, attached(3 + 2 * bound + 1)) == bound
    assert handled(sub, attached(3 + 2 * bound + 2)) == bound


def test_samples_skipped_before_a_publishers_first_handled_one_are_counted(sub: Any) -> None:
    """Keep-last skips the head of a burst of a publisher not handled yet: the gap counts."""
    assert handled(sub, attached(1, GID_B)) == 0
    backlog = collections.deque(
        [
            *(attached(n) for n in range(1, 16)),
            *(attached(n, GID_B) for n in (2, 3, 4)),
            sample(None),
            *(attached(n) for n in range(16, 16 + sub.depth)),
        ]
    )
    sub._keep_last(backlog)
    assert len(backlog) == sub.depth
    assert handled(sub, *backlog) == 15 + 1  # GID_A's 1..15 and the one without attachment
    assert handled(sub, attached(5, GID_B)) == 15 + 1 + 3


def test_a_malformed_attachment_is_counted_and_reported_once(
    sub: Any, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING, logger="pyconnect.transport"):
        assert handled(sub, sample(b"\x01\x02\x03"), sample(b"x" * 40), attached(1)) == 0
    assert sub.bad_attachment_count == 2
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warnings == [
        "agent 'chat' (sub std_msgs/msg/String) on /chat: publisher with an unreadable "
        "attachment: attachment of 3 bytes, expected 33 (rmw_zenoh's sequence number, "
        "source timestamp and GID); its samples are handed on, not checked for gaps"
    ]


def test_a_bogus_sequence_from_a_raw_session(make_peer: PeerFactory, locator: str) -> None:
    """The reviewer's case end to end: five samples, one with sequence 2**62, none lost."""
    sub = make_peer("victim").add_agent(
        conn_name="chat", conn_type="sub", data_interface="std_msgs/msg/String"
    )
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("connect/endpoints", f'["{locator}"]')
    session = zenoh.open(config)
    try:
        publisher = session.declare_publisher(sub.key)
        assert wait_for(lambda: bool(getattr(publisher.matching_status, "matching", False)))
        for sequence in (1, 2, 2**62, 3, 4):
            publisher.put(HELLO, attachment=zenoh_attachment(sequence, 0, GID_A))
        assert wait_for(lambda: sub.message_count == 5)
        assert sub.dropped_count == 0
    finally:
        session.close()


@pytest.mark.parametrize(
    ("depth", "problem"),
    [
        (0, "depth must be >= 1, got 0"),
        (True, "depth must be an int >= 1, got True"),
        ("10", "depth must be an int >= 1, got '10'"),
        (2.5, "depth must be an int >= 1, got 2.5"),
    ],
)
def test_a_depth_that_is_not_an_int_of_at_least_one_is_refused(
    make_peer: PeerFactory, depth: object, problem: str
) -> None:
    peer = make_peer("listener")
    with pytest.raises(PyconnectError) as caught:
        peer.add_agent(
            conn_name="chat", conn_type="sub", data_interface="std_msgs/msg/String", depth=depth
        )
    assert str(caught.value) == f"agent 'chat' (sub std_msgs/msg/String): {problem}"
    assert peer.agents == {}


@pytest.mark.parametrize("timeout", [1e10, -1.0, float("nan"), "soon"])
def test_wait_for_message_refuses_a_timeout_no_wait_can_take(sub: Any, timeout: Any) -> None:
    """1e10 s raised OverflowError from threading, a str a TypeError: said like every timeout."""
    with pytest.raises(PyconnectError, match=r"^agent 'chat' \(sub .*\): wait_for_message: "):
        sub.wait_for_message(timeout)
