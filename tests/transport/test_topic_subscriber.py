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
from pyconnect.transport import other_type_keys, topic_subscriber
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


# -- publishers of other types ---------------------------------------------------------------------
STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"


def other_token(sub: Any, entity_id: int, type_hash: str) -> str:
    """The token of a String publisher on ``sub``'s topic, of ``type_hash`` (not String's)."""
    return (
        f"@ros2_lv/{sub.peer.domain_id}/abc/1/{entity_id}/MP/%/%/other/%chat/"
        f"std_msgs::msg::dds_::String_/{type_hash}/::,:,:,:,,"
    )


def fake_hash(number: int) -> str:
    return f"RIHS01_{number:064x}"


def listened(sub: Any) -> set[str]:
    """The keys of other types ``sub`` listens on, once no declaration is under way."""
    others = dict(sub._other_types.listened)
    if None in others.values() or sub._other_types.worker is not None:
        return {"(busy)"}
    return set(others)


def test_a_key_of_another_type_is_listened_to_while_a_publisher_token_names_it(
    make_peer: PeerFactory,
) -> None:
    """The reviewer's leak: a subscriber on another type's key stayed once its publishers went."""
    peer = make_peer("victim")
    sub = peer.add_agent(conn_name="chat", conn_type="sub", data_interface="std_msgs/msg/Int32")
    liveliness = peer.session.liveliness()
    old_a = liveliness.declare_token(other_token(sub, 10, fake_hash(1)))
    old_b = liveliness.declare_token(other_token(sub, 11, fake_hash(1)))
    string = liveliness.declare_token(other_token(sub, 12, STRING_HASH))
    old_key = topic_subscriber.keys.data_key(
        peer.domain_id, "/chat", "std_msgs/msg/String", fake_hash(1)
    )
    string_key = topic_subscriber.keys.data_key(
        peer.domain_id, "/chat", "std_msgs/msg/String", STRING_HASH
    )
    assert wait_for(lambda: listened(sub) == {old_key, string_key})
    peer.session.put(string_key, HELLO, attachment=zenoh_attachment(1, 0, GID_A))
    assert wait_for(lambda: sub.type_mismatch_count == 1)  # still counted while listened to
    old_a.undeclare()  # old_b still publishes on old_key
    string.undeclare()
    assert wait_for(lambda: listened(sub) == {old_key})
    old_b.undeclare()
    assert wait_for(lambda: listened(sub) == set())
    assert sub._other_types.publishers == {}


def test_at_most_max_other_types_keys_are_listened_to(
    make_peer: PeerFactory, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(other_type_keys, "MAX_OTHER_TYPES", 3)
    peer = make_peer("victim")
    sub = peer.add_agent(conn_name="chat", conn_type="sub", data_interface="std_msgs/msg/String")
    liveliness = peer.session.liveliness()

    def key(number: int) -> str:
        return topic_subscriber.keys.data_key(
            peer.domain_id, "/chat", "std_msgs/msg/String", fake_hash(number)
        )

    with caplog.at_level(logging.WARNING, logger="pyconnect.transport"):
        tokens = [liveliness.declare_token(other_token(sub, n, fake_hash(n))) for n in range(5)]
        assert wait_for(lambda: len(sub._other_types.publishers) == 5)
        assert wait_for(lambda: listened(sub) == {key(0), key(1), key(2)})
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warnings == [
        "agent 'chat' (sub std_msgs/msg/String) on /chat: publishers of more than 3 other "
        "types; samples of the types beyond those are not listened to (not counted in "
        "type_mismatch_count)"
    ]
    tokens[0].undeclare()
    tokens[2].undeclare()
    assert wait_for(lambda: listened(sub) == {key(1), key(3), key(4)})
    for token in tokens[3:] + tokens[1:2]:
        token.undeclare()
    assert wait_for(lambda: listened(sub) == set())


def test_a_wildcard_type_hash_token_does_not_make_good_samples_mismatches(
    make_peer: PeerFactory, caplog: pytest.LogCaptureFixture
) -> None:
    """The reviewer's case: a token with type hash '*' had the sub listen on .../String_/*,
    its own key included: every good sample was also counted and warned about."""
    got: list[object] = []
    peer = make_peer("victim")
    sub = peer.add_agent(
        conn_name="chat",
        conn_type="sub",
        data_interface="std_msgs/msg/String",
        response_func=got.append,
    )
    pub = peer.add_agent(
        conn_name="chat", agent_name="out", conn_type="pub", data_interface="std_msgs/msg/String"
    )
    with caplog.at_level(logging.WARNING, logger="pyconnect.transport"):
        evil = peer.session.liveliness().declare_token(other_token(sub, 10, "*"))
        good = peer.session.liveliness().declare_token(other_token(sub, 11, fake_hash(1)))
        assert wait_for(lambda: len(listened(sub) - {"(busy)"}) == 1)  # the good one only
        for number in range(5):
            pub.send(f"m{number}")
        assert wait_for(lambda: len(got) == 5)
        evil.undeclare()
        good.undeclare()
    assert sub.type_mismatch_count == 0
    assert [r for r in caplog.records if r.levelno >= logging.WARNING] == []


def test_a_key_that_meets_the_subscriptions_own_is_never_listened_to(sub: Any) -> None:
    """However a token came to name one (a wildcard in its type name or hash)."""

    def token(type_name: str, type_hash: str) -> Any:
        return topic_subscriber.keys.Token(
            key="@ros2_lv/0/abc/1/2/MP/%/%/evil/%chat/x/y/::,:,:,:,,",
            zid="abc",
            node_id="1",
            entity_id="2",
            kind=topic_subscriber.keys.PUBLISHER,
            enclave="/",
            namespace="/",
            node_name="evil",
            name="/chat",
            type_name=type_name,
            type_hash=type_hash,
        )

    assert sub._other_types.key_of(token("std_msgs/msg/String", "*")) is None
    assert sub._other_types.key_of(token("std_msgs/msg/String", "$*")) is None
    assert sub._other_types.key_of(token("std_msgs/msg/String", "**")) is None
    assert sub._other_types.key_of(token("std_msgs/msg/Int32", STRING_HASH)) is not None
