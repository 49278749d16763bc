"""The wire codec of one type (pyconnect.codecs.wire_codec): input that is not CDR bytes."""

from __future__ import annotations

import numpy as np
import pytest

from pyconnect.codecs import wire
from pyconnect.errors import DecodeError


def test_decoding_a_str_says_bytes_were_expected() -> None:
    # memoryview's TypeError named neither the type nor what it wanted.
    for call in (wire.decode, wire.to_dict):
        with pytest.raises(DecodeError) as raised:
            call("abc", "std_msgs/msg/String")
        assert str(raised.value) == ("std_msgs/msg/String: expected bytes-like CDR data, got str")
    with pytest.raises(DecodeError, match=r"^std_msgs/msg/String: expected bytes-like CDR data"):
        wire.decode(None, "std_msgs/msg/String")


def test_bytes_like_inputs_still_decode() -> None:
    cdr = wire.encode("hi", "std_msgs/msg/String")
    assert wire.decode(bytearray(cdr), "std_msgs/msg/String") == "hi"
    assert wire.decode(np.frombuffer(cdr, np.uint8), "std_msgs/msg/String") == "hi"
