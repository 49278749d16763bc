"""A peer's ``pub`` agent: the options it refuses before anything is declared."""

from __future__ import annotations

import pytest

from pyconnect.errors import PyconnectError
from pyconnect.transport import rmw_zenoh_keys as keys
from tests.transport.conftest import PeerFactory


@pytest.mark.parametrize(
    ("depth", "problem"),
    [
        (0, "depth must be >= 1, got 0"),
        (-1, "depth must be >= 1, got -1"),
        (True, "depth must be an int >= 1, got True"),
        ("abc", "depth must be an int >= 1, got 'abc'"),
        (2.5, "depth must be an int >= 1, got 2.5"),
    ],
)
def test_a_depth_that_is_not_an_int_of_at_least_one_is_refused(
    make_peer: PeerFactory, depth: object, problem: str
) -> None:
    """The depth goes into the liveliness token rmw_zenoh parses: a sub refused a wrong one,
    a pub wrote any value there."""
    peer = make_peer("talker")
    with pytest.raises(PyconnectError) as caught:
        peer.add_agent(
            conn_name="chat", conn_type="pub", data_interface="std_msgs/msg/String", depth=depth
        )
    assert str(caught.value) == f"agent 'chat' (pub std_msgs/msg/String): {problem}"
    assert peer.agents == {}
    assert peer.graph.count(kind="MP", name="/chat") == 0  # no token was declared


def test_a_depth_goes_into_the_token(make_peer: PeerFactory) -> None:
    pub = make_peer("talker").add_agent(
        conn_name="chat", conn_type="pub", data_interface="std_msgs/msg/String", depth=3
    )
    assert pub.token_key.endswith(f"/{keys.qos_chunk(depth=3)}")


def test_only_subscriptions_of_its_type_count_for_only_if_subscribed(
    make_peer: PeerFactory,
) -> None:
    """A subscription of another type is on another key: it never gets these samples."""
    from tests.transport.conftest import wait_for

    listener, talker = make_peer("listener"), make_peer("talker")
    listener.add_agent(conn_name="chat", conn_type="sub", data_interface="std_msgs/msg/Int32")
    pub = talker.add_agent(
        conn_name="chat",
        conn_type="pub",
        data_interface="std_msgs/msg/String",
        only_if_subscribed=True,
    )
    assert wait_for(lambda: talker.graph.count(kind=keys.SUBSCRIPTION, name="/chat") == 1)
    assert pub.subscriber_count == 0
    assert pub.send("hello") is False
    listener.add_agent(
        conn_name="chat", agent_name="text", conn_type="sub", data_interface="std_msgs/msg/String"
    )
    assert wait_for(lambda: pub.subscriber_count == 1)
    assert pub.send("hello") is True
