"""The lookups type-check for users: the README's calls pass ``mypy --strict``."""

from __future__ import annotations

from pathlib import Path

import pytest
from mypy import api
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci

from pyconnect import codecs
from pyconnect.errors import CodecError, CodecNotFoundError

USE = """
from typing import Any
from sensor_msgs.msg import Image
from std_srvs.srv import SetBool
from pyconnect import codecs

def roundtrip(msg: Any) -> Any:
    codec = codecs.lookup(Image)
    value = codec.decode(msg)
    lossless: bool = codec.lossless
    return codec.encode(value), lossless

request = codecs.lookup_service(SetBool).request.encode({"data": True})
goal = codecs.lookup_action("test_msgs/action/Fibonacci").goal.decode(request)
wrong: int = codecs.lookup(Image).msg_type
"""


def test_readme_lookups_type_check(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MYPYPATH", str(Path(__file__).resolve().parents[2] / "src"))
    script = tmp_path / "use.py"
    script.write_text(USE)
    out, _, status = api.run([
        "--strict", "--no-incremental", "--ignore-missing-imports", "--follow-imports=silent",
        "--cache-dir", str(tmp_path / "cache"), "--config-file", "", str(script),
    ])  # fmt: skip
    errors = [line.split(": error: ", 1)[1] for line in out.splitlines() if ": error: " in line]
    assert status == 1
    assert errors == [
        'Incompatible types in assignment (expression has type "str", variable has type "int")  [assignment]'
    ]


def test_service_and_action_codecs_name_their_parts() -> None:
    service = codecs.lookup_service(SetBool)
    assert service.request.decode(service.request.encode({"data": True})) == {"data": True}
    with pytest.raises(CodecError) as error:
        codecs.lookup(SetBool).decode(SetBool.Request())
    assert str(error.value) == (
        "std_srvs/srv/SetBool is a service type: decode one of its parts (request, response, "
        "event), e.g. codecs.lookup_service(...).request.decode(...)"
    )
    assert codecs.lookup_action(Fibonacci).goal.msg_type == "test_msgs/action/Fibonacci_Goal"
    with pytest.raises(CodecNotFoundError) as not_action:
        codecs.lookup_action(SetBool)
    assert str(not_action.value) == "std_srvs/srv/SetBool is not an action type"
