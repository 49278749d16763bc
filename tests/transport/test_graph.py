"""A peer's Graph tells its watchers of new tokens and, when asked, of tokens that disappear."""

from __future__ import annotations

from pyconnect.transport import rmw_zenoh_keys as keys
from pyconnect.transport.rmw_zenoh_keys import Token
from tests.transport.conftest import PeerFactory, wait_for

HASH = "RIHS01_" + "ab" * 32


def publisher_token(domain_id: int, entity_id: int) -> str:
    return (
        f"@ros2_lv/{domain_id}/abc/1/{entity_id}/MP/%/%/other/%chat/"
        f"std_msgs::msg::dds_::String_/{HASH}/::,:,:,:,,"
    )


def keys_on_chat(tokens: list[Token]) -> list[str]:
    """The keys of ``tokens`` on /chat (the peer's own node token is in the graph too)."""
    return [token.key for token in tokens if token.name == "/chat"]


def test_watchers_hear_new_tokens_and_those_that_go(make_peer: PeerFactory) -> None:
    peer = make_peer("watcher")
    key = publisher_token(peer.domain_id, 7)
    new: list[Token] = []
    gone: list[Token] = []
    only_new: list[Token] = []  # a watcher without ``gone``, as before
    peer.graph.watch(new.append, gone=gone.append)
    peer.graph.watch(only_new.append)
    token = peer.session.liveliness().declare_token(key)
    assert wait_for(lambda: keys_on_chat(new) == [key])
    assert keys_on_chat(only_new) == [key]
    assert gone == []
    token.undeclare()
    assert wait_for(lambda: keys_on_chat(gone) == [key])
    assert gone[0].kind == keys.PUBLISHER
    assert keys_on_chat(new) == [key]


def test_unwatch_stops_both_calls(make_peer: PeerFactory) -> None:
    peer = make_peer("watcher")
    new: list[Token] = []
    gone: list[Token] = []
    peer.graph.watch(new.append, gone=gone.append)
    first = peer.session.liveliness().declare_token(publisher_token(peer.domain_id, 7))
    assert wait_for(lambda: len(keys_on_chat(new)) == 1)
    peer.graph.unwatch(new.append)
    first.undeclare()
    second = peer.session.liveliness().declare_token(publisher_token(peer.domain_id, 8))
    assert wait_for(lambda: peer.graph.count(kind=keys.PUBLISHER, name="/chat") == 1)
    second.undeclare()
    assert wait_for(lambda: peer.graph.count(kind=keys.PUBLISHER, name="/chat") == 0)
    assert (len(keys_on_chat(new)), gone) == (1, [])


def test_a_token_never_parsed_is_not_reported_gone(make_peer: PeerFactory) -> None:
    """A wildcard token is not in the graph: its disappearance is no one's news either."""
    peer = make_peer("watcher")
    gone: list[Token] = []
    peer.graph.watch(lambda token: None, gone=gone.append)
    bad = peer.session.liveliness().declare_token(
        publisher_token(peer.domain_id, 7).replace(HASH, "*")
    )
    good = peer.session.liveliness().declare_token(publisher_token(peer.domain_id, 8))
    assert wait_for(lambda: peer.graph.count(kind=keys.PUBLISHER, name="/chat") == 1)
    bad.undeclare()
    good.undeclare()
    assert wait_for(lambda: len(gone) == 1)
    assert [token.entity_id for token in gone] == ["8"]
