"""parse_token takes rmw_zenoh's tokens and refuses any whose chunks would make a wildcard key."""

from __future__ import annotations

import pytest

from pyconnect.transport import rmw_zenoh_keys as keys

STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
# As rmw_zenoh (Jazzy) declares them: a node, a publisher with default QoS, a subscription.
REAL_TOKENS = [
    "@ros2_lv/0/5a8c1b2e4f6d7a9b0c1d2e3f4a5b6c7d/0/0/NN/%/%/talker",
    "@ros2_lv/0/5a8c1b2e4f6d7a9b0c1d2e3f4a5b6c7d/0/10/MP/%/%/talker/%chatter/"
    f"std_msgs::msg::dds_::String_/{STRING_HASH}/::,7:,:,:,,",
    "@ros2_lv/42/1f/3/4/MS/%/%ns/_hidden_node/%ns%chatter/"
    f"std_msgs::msg::dds_::String_/{STRING_HASH}/2:1:,:,:,:,,",
]
EVIL = "@ros2_lv/231/abc/1/2/MP/%/%/evil/%chatter/std_msgs::msg::dds_::String_"
QOS = "::,:,:,:,,"


@pytest.mark.parametrize("token", REAL_TOKENS)
def test_real_tokens_are_parsed(token: str) -> None:
    parsed = keys.parse_token(token)
    assert parsed is not None
    assert parsed.key == token


def test_a_real_publisher_tokens_fields() -> None:
    parsed = keys.parse_token(REAL_TOKENS[1])
    assert parsed is not None
    assert (parsed.kind, parsed.name, parsed.type_name, parsed.type_hash) == (
        "MP",
        "/chatter",
        "std_msgs/msg/String",
        STRING_HASH,
    )


@pytest.mark.parametrize(
    "token",
    [
        f"{EVIL}/*/{QOS}",  # the reviewer's: a sub listened on .../String_/* (its own key too)
        f"{EVIL}/**/{QOS}",
        f"{EVIL}/$*/{QOS}",
        f"{EVIL}/RIHS01_$*/{QOS}",
        f"{EVIL}/RIHS01_x/{QOS}",
        f"{EVIL}/RIHS01_{STRING_HASH[7:].upper()}/{QOS}",  # rosidl writes lowercase hex
        f"{EVIL}/{STRING_HASH[:-1]}/{QOS}",
        f"{EVIL}/RIHS02_{STRING_HASH[7:]}/{QOS}",
        f"{EVIL}/{STRING_HASH}/*",
        f"@ros2_lv/231/abc/1/2/MP/%/%/evil/*/std_msgs::msg::dds_::String_/{STRING_HASH}/{QOS}",
        f"@ros2_lv/231/abc/1/2/MP/%/%/evil/%chatter/*/{STRING_HASH}/{QOS}",
        f"@ros2_lv/231/abc/1/2/MP/%/%/evil/%chatter/std_msgs::msg::dds_::*_/{STRING_HASH}/{QOS}",
        f"@ros2_lv/*/abc/1/2/MP/%/%/evil/%chatter/std_msgs::msg::dds_::String_/{STRING_HASH}/{QOS}",
        f"@ros2_lv/**/MP/%/%/evil/%chatter/std_msgs::msg::dds_::String_/{STRING_HASH}/{QOS}",
        "@ros2_lv/231/*/1/1/NN/%/%/evil",
        "@ros2_lv/231/abc/*/1/NN/%/%/evil",
        "@ros2_lv/231/abc/1/**/NN/%/%/evil",
        "@ros2_lv/231/abc/1/1/NN/%/%/ev?il",
        "@ros2_lv/231/abc/1/1/NN/%/%/ev#il",
        "@ros2_lv/231/abc/1/1/NN/$*/%/evil",
        "@ros2_lv/231/abc/1/1/NN//%/evil",
        "@ros2_lv/x1/abc/1/1/NN/%/%/evil",
        "@ros2_lv/231/xyz/1/1/NN/%/%/evil",
        "@ros2_lv/231/abc/1a/1/NN/%/%/evil",
        "@ros2_lv/231/abc/1/-1/NN/%/%/evil",
    ],
)
def test_a_token_with_a_wildcard_or_a_malformed_chunk_is_refused(token: str) -> None:
    assert keys.parse_token(token) is None


def test_the_type_hash_pattern_is_rmw_zenohs() -> None:
    assert keys.TYPE_HASH.fullmatch(STRING_HASH)
    assert not keys.TYPE_HASH.fullmatch("RIHS01_*")
