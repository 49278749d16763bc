"""Parsing interface text as rosidl's build does: its text survives, and what rosidl cannot
convert is a one-line DefinitionError naming the file and line (never an exit)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, NoReturn

import pytest

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.parse import ParsedInterfaces, iter_messages, parse_interface_text
from tests.missing_modules import without


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("time stamp\nint32 v\n", "msg/Stamp.msg:1: unknown type 'time'"),
        ("# c\nint32 v\nduration[<=3] d  # ROS 1\n", "msg/Stamp.msg:3: unknown type 'duration'"),
    ],
)
def test_ros1_time_and_duration_are_unknown_types(text: str, expected: str) -> None:
    with pytest.raises(DefinitionError) as caught:
        parse_interface_text("my_pkg", Path("msg/Stamp.msg"), text, ParsedInterfaces())
    assert str(caught.value) == expected


def test_a_field_named_time_is_fine() -> None:
    parsed = ParsedInterfaces()
    parse_interface_text("my_pkg", Path("msg/T.msg"), "int32 time\nint32 duration\n", parsed)
    assert [f.name for f in parsed.messages[0].fields] == ["time", "duration"]


def test_rosidl_template_exiting_is_a_definition_error(monkeypatch: pytest.MonkeyPatch) -> None:
    import rosidl_adapter.resource

    def exits(*_args: Any, **_kwargs: Any) -> NoReturn:
        raise SystemExit(1)

    monkeypatch.setattr(rosidl_adapter.resource, "evaluate_template", exits)
    with pytest.raises(DefinitionError) as caught:
        parse_interface_text("my_pkg", Path("msg/T.msg"), "int32 v\n", ParsedInterfaces())
    assert str(caught.value) == "msg/T.msg: rosidl cannot convert it to IDL (it exited)"


def _parse(path: str, text: str) -> ParsedInterfaces:
    parsed = ParsedInterfaces()
    parse_interface_text("my_pkg", Path(path), text, parsed)
    return parsed


def _error(path: str, text: str) -> str:
    with pytest.raises(DefinitionError) as caught:
        _parse(path, text)
    return str(caught.value)


def test_non_ascii_string_defaults_and_constants_keep_their_text() -> None:
    # rosidl_adapter garbles UTF-8 on its way to IDL and its build repairs it; so must we.
    parsed = ParsedInterfaces()
    msg = 'wstring ws "ωmega"  # ñ\nstring s "café"\nstring C="ü"\nwstring W="€"\n'
    srv = 'string s "café"\n---\nwstring<=9 ws "ωmega"\nstring C="ü"\n'
    action = 'string s "café"\n---\nwstring ws "ωmega"\n---\nwstring W="€"\nstring s "ハロー"\n'
    parse_interface_text("my_pkg", Path("msg/W.msg"), msg, parsed)
    parse_interface_text("my_pkg", Path("srv/S.srv"), srv, parsed)
    parse_interface_text("my_pkg", Path("action/A.action"), action, parsed)
    found = {
        m.full_name: (
            [(f.name, f.default) for f in m.fields],
            [(c.name, c.value) for c in m.constants],
        )
        for m in iter_messages(parsed)
        if m.full_name.split("/")[2]
        in {"W", "S_Request", "S_Response", "A_Goal", "A_Result", "A_Feedback"}
    }
    assert found == {
        "my_pkg/msg/W": ([("ws", "ωmega"), ("s", "café")], [("C", "ü"), ("W", "€")]),
        "my_pkg/srv/S_Request": ([("s", "café")], []),
        "my_pkg/srv/S_Response": ([("ws", "ωmega")], [("C", "ü")]),
        "my_pkg/action/A_Goal": ([("s", "café")], []),
        "my_pkg/action/A_Result": ([("ws", "ωmega")], []),
        "my_pkg/action/A_Feedback": ([("s", "ハロー")], [("W", "€")]),
    }


def test_escapes_decode_as_in_rosidls_build() -> None:
    # `\xc3\xa9` is the UTF-8 of "é": rosidl's ISO-8859-1 write and UTF-8 read make it "é".
    parsed = _parse("msg/E.msg", 'string s "\\xc3\\xa9"\nstring t "\\x41"\n')
    assert [f.default for f in parsed.messages[0].fields] == ["é", "A"]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            'int32 a\nstring s "\\u03c9"\n',
            "msg/E.msg:2: rosidl cannot convert it to IDL "
            "('ω' is not ISO-8859-1, the encoding rosidl writes IDL in)",
        ),
        (
            'int32 a\nint32 b\nstring s "\\xff"\n',
            "msg/E.msg:3: rosidl cannot convert it to IDL "
            "(bytes b'\\xff' are not UTF-8, the encoding rosidl reads IDL in)",
        ),
    ],
)
def test_text_rosidls_build_cannot_write_is_refused_with_its_line(text: str, expected: str) -> None:
    assert _error("msg/E.msg", text) == expected


@pytest.mark.parametrize(
    ("path", "text", "expected"),
    [
        (
            "srv/AddTwo.srv",
            "int32 a\nint32 b\n---\nint32 ok\nint65 sum\n",
            "srv/AddTwo.srv:5: unknown type 'int65'",
        ),
        (
            "srv/AddTwo.srv",
            "int32 a\nint65 b\n---\nint32 ok\n",
            "srv/AddTwo.srv:2: unknown type 'int65'",
        ),
        (
            "action/Do.action",
            "int32 g\n---\nint32 r\n---\nint32 f\nfloat65 x\n",
            "action/Do.action:6: unknown type 'float65'",
        ),
        (
            "action/Do.action",
            "int32 g\n---\n# r\nfloat65 r\n---\nint32 f\n",
            "action/Do.action:4: unknown type 'float65'",
        ),
        (
            "srv/AddTwo.srv",
            "int32 a\nint32 b\nint32 sum\n",
            "srv/AddTwo.srv: Could not find separator '---' between request and response",
        ),
    ],
)
def test_srv_and_action_errors_name_the_line(path: str, text: str, expected: str) -> None:
    assert _error(path, text) == expected


def test_constants_rosidls_template_rejects_name_the_line_and_rosidls_reason() -> None:
    # rosidl cuts the value at `#` and its template cannot unescape the trailing backslash.
    text = 'int32 a\nstring S="he said \\"hi\\" # x"\nint32 b\n'
    assert _error("msg/C.msg", text) == (
        "msg/C.msg:2: rosidl cannot convert it to IDL (UnicodeDecodeError processing template "
        "'struct.idl.em': 'unicodeescape' codec can't decode byte 0x5c in position 11: "
        "\\ at end of string)"
    )
    srv = "int32 a\n---\n" + text
    assert _error("srv/C.srv", srv).startswith("srv/C.srv:4: rosidl cannot convert it to IDL (")


def test_defaults_rosidls_idl_parser_rejects_name_the_line() -> None:
    # A default ending in a backslash escapes the closing quote of the IDL literal.
    assert _error("msg/B.msg", 'int32 a\nstring s "\\\\"\n') == (
        "msg/B.msg:2: rosidl cannot parse the IDL it converts it to "
        '(No terminal matches \'"\' in the current parser context @default (value="\\") ^)'
    )


@pytest.mark.parametrize(
    "module", ["rosidl_adapter", "rosidl_parser", "rosidl_generator_type_description"]
)
def test_without_rosidl_one_definition_error_says_what_to_install(
    monkeypatch: pytest.MonkeyPatch, module: str
) -> None:
    # A definition rosidl would refuse made the search for its line import rosidl_adapter again;
    # without the type-hash generator, hashing raised a bare ModuleNotFoundError.
    without(monkeypatch, module)
    for text in ("int64 num\n", "int64 num\nbad line here\n"):
        with pytest.raises(DefinitionError) as caught:
            parse_interface_text("my_msgs", Path("msg/Num.msg"), text, ParsedInterfaces())
        assert str(caught.value) == (
            "reading interface definitions needs rosidl's parsers (No module named "
            f"'{module}'): pip install 'pyconnect-ros[ros]' or source a ROS 2 Jazzy install"
        )


class _CountingMessageFails:
    """Wraps parse._message_fails, which renders and parses one message: how often, how much."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        from pyconnect.typesys import parse

        self.calls = 0
        self.lines = 0
        self._real = parse._message_fails
        monkeypatch.setattr(parse, "_message_fails", self)

    def __call__(self, package: str, name: str, lines: list[str], *, upto: Any) -> bool:
        self.calls += 1
        self.lines += len(lines)
        result: bool = self._real(package, name, lines, upto=upto)
        return result


def test_a_default_rosidls_idl_parser_rejects_is_found_with_one_small_parse(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Trying each prefix of the message parsed it quadratically: 45 s for 200 fields.
    counted = _CountingMessageFails(monkeypatch)
    text = "".join(f"int32 f{i}\n" for i in range(64)) + 'string s "a\\\\"\n'
    assert _error("msg/Big.msg", text).startswith(
        "msg/Big.msg:65: rosidl cannot parse the IDL it converts it to ("
    )
    assert (counted.calls, counted.lines) == (1, 1)


@pytest.mark.parametrize(
    ("last", "expected"),
    [
        # rosidl's template cannot unescape the trailing backslash of a constant
        ('string S="he said \\"hi\\" # x"', "rosidl cannot convert it to IDL ("),
        ("int65 x", "unknown type 'int65'"),
    ],
)
def test_the_line_search_parses_a_linear_amount_of_text(
    monkeypatch: pytest.MonkeyPatch, last: str, expected: str
) -> None:
    counted = _CountingMessageFails(monkeypatch)
    count = 200
    text = "".join(f"int32 f{i}\n" for i in range(count)) + last + "\n"
    assert _error("msg/Big.msg", text).startswith(f"msg/Big.msg:{count + 1}: {expected}")
    # the whole message, the empty one, then both halves of each half that fails
    assert counted.calls <= 2 * math.ceil(math.log2(count + 1)) + 2
    assert counted.lines <= 4 * (count + 1)


def test_a_fault_of_two_lines_is_found_in_a_logarithmic_number_of_parses(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    counted = _CountingMessageFails(monkeypatch)
    count = 200
    text = "".join(f"int32 f{i}\n" for i in range(count)) + "int32 f7\n"
    assert _error("msg/Big.msg", text) == (
        f"msg/Big.msg:{count + 1}: the fields iterable contains duplicate names: f7"
    )
    # no half fails alone; a bisection of the prefixes follows
    assert counted.calls <= 3 * math.ceil(math.log2(count + 1)) + 2


def test_the_line_search_keeps_to_the_failing_part_of_a_service(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    counted = _CountingMessageFails(monkeypatch)
    text = "".join(f"int32 f{i}\n" for i in range(50)) + "---\nint32 ok\nint65 x\nint32 y\n"
    assert _error("srv/S.srv", text) == "srv/S.srv:53: unknown type 'int65'"
    assert counted.calls <= 8


_SAME_IDL = """module my_pkg {
  module msg {
    module Val_Constants {
      const int8 VALUE = 1;  // value=300 in a comment is no declaration
    };
    struct Val {
      @default (value=1)
      int32 a;
      @verbatim (language="comment", text=
        "float value;")
      @default (value=1e39)
      float value;
    };
  };
};
"""
_SAME_SRV_IDL = """module my_pkg {
  module srv {
    struct Same_Request {
      @default (value=1.0)
      float x;
    };
    struct Same_Response {
      @default (value=1e39)
      float x;
    };
  };
};
"""


@pytest.mark.parametrize(
    ("path", "text", "expected"),
    [
        (
            "srv/Same.srv",
            "float32 x\n---\nfloat32 x 1e39\n",
            "srv/Same.srv:3: the default of x is out of float32's range",
        ),
        (
            "srv/Same.srv",
            "float32 X=1.0\n---\nfloat32 X=1e39\n",
            "srv/Same.srv:3: the value of X is out of float32's range",
        ),
        (
            "action/Same.action",
            "float32 speed\n---\nbool ok\n---\nfloat32 speed nan\n",
            "action/Same.action:5: the default of speed is not finite",
        ),
        (
            "action/Same.action",
            "float32 speed\n---\nfloat32 speed\n---\n# c\nfloat32 speed nan\n",
            "action/Same.action:6: the default of speed is not finite",
        ),
        ("msg/Val.idl", _SAME_IDL, "msg/Val.idl:12: the default of value is out of float32's"),
        ("srv/Same.idl", _SAME_SRV_IDL, "srv/Same.idl:9: the default of x is out of float32's"),
    ],
)
def test_a_members_error_names_the_line_of_its_own_message(
    path: str, text: str, expected: str
) -> None:
    # The first line of the file declaring that name was given: the request's, an annotation's.
    assert _error(path, text).startswith(expected)
