"""Defaults and constants of .idl text are checked as rosidl_adapter checks those of .msg text:
integer ranges, integers, booleans, string bounds and array lengths, with the declaring line."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.model import DefaultValue
from pyconnect.typesys.parse import ParsedInterfaces, parse_interface_text


def _idl(declarations: str, constants: str = "") -> str:
    module = f"    module M_Constants {{\n      {constants}\n    }};\n" if constants else ""
    return (
        "module p {\n  module msg {\n    typedef int32 int32__2[2];\n"
        f"{module}    struct M {{\n      int32 first;\n      {declarations}\n    }};\n  }};\n}};\n"
    )


def _parse(text: str) -> ParsedInterfaces:
    parsed = ParsedInterfaces()
    parse_interface_text("p", Path("msg/M.idl"), text, parsed)
    return parsed


@pytest.mark.parametrize(
    ("constant", "expected"),
    [
        ("const uint8 BIG = 300;", "the value of BIG is out of uint8's range: 300 (0 <= x <= 255)"),
        ("const int8 NEG = -200;",
         "the value of NEG is out of int8's range: -200 (-128 <= x <= 127)"),
        ("const int32 HALF = 1.5;",
         "the value of HALF is not an int32 value: 1.5 (expected an integer)"),
        ("const boolean TWO = 2;",
         "the value of TWO is not a bool value: 2 (expected TRUE, FALSE, 1 or 0)"),
    ],
)  # fmt: skip
def test_constants_out_of_their_type_are_refused_at_their_line(
    constant: str, expected: str
) -> None:
    with pytest.raises(DefinitionError) as caught:
        _parse(_idl("int32 x;", constant))
    assert str(caught.value) == f"msg/M.idl:5: {expected}"


@pytest.mark.parametrize(
    ("declaration", "expected"),
    [
        ("@default (value=300)\n      octet o;",
         "the default of o is out of byte's range: 300 (0 <= x <= 255)"),
        ("@default (value=-1)\n      uint32 u;",
         "the default of u is out of uint32's range: -1 (0 <= x <= 4294967295)"),
        ("@default (value=18446744073709551616)\n      uint64 u;",
         "the default of u is out of uint64's range: 18446744073709551616 "
         "(0 <= x <= 18446744073709551615)"),
        ("@default (value=1.7)\n      int32 i;",
         "the default of i is not an int32 value: 1.7 (expected an integer)"),
        ("@default (value=TRUE)\n      int16 i;",
         "the default of i is not an int16 value: True (expected an integer)"),
        ("@default (value=2)\n      boolean b;",
         "the default of b is not a bool value: 2 (expected TRUE, FALSE, 1 or 0)"),
        # rosidl's generators would make "false" True, by its truth
        ("@default (value=false)\n      boolean b;",
         "the default of b is not a bool value: 'false' (expected TRUE, FALSE, 1 or 0)"),
        ("@default (value=FALSE)\n      double d;",
         "the default of d is not a float64 value: False (expected a number)"),
        ('@default (value="abcdef")\n      string<3> s;',
         "the default of s is too long for string<=3: 'abcdef' (6 characters, at most 3)"),
        ('@default (value="ωmega")\n      wstring<4> w;',
         "the default of w is too long for wstring<=4: 'ωmega' (5 characters, at most 4)"),
        ('@default (value="(1, 2, 3)")\n      int32__2 a;',
         "the default of a does not fit int32[2]: (1, 2, 3) (3 elements, exactly 2)"),
        ('@default (value="[1, 2, 3]")\n      sequence<int32, 2> q;',
         "the default of q is too long for int32[<=2]: (1, 2, 3) (3 elements, at most 2)"),
        ('@default (value="[1, 300]")\n      sequence<uint8> q;',
         "the default of q is out of uint8's range: 300 (0 <= x <= 255)"),
        ("@default (value=\"('ab', 'abcd')\")\n      sequence<string<3>> q;",
         "the default of q is too long for string<=3: 'abcd' (4 characters, at most 3)"),
        ('@default (value="(True, 2)")\n      sequence<boolean> q;',
         "the default of q is not a bool value: 2 (expected TRUE, FALSE, 1 or 0)"),
        ("@default (value=3)\n      sequence<int32> q;",
         "the default of q is not a list of values for int32[]: 3"),
        ('@default (value="[1, 2")\n      sequence<int32> q;',
         "the default of q is not a list of values for int32[]: '[1, 2'"),
    ],
)  # fmt: skip
def test_defaults_out_of_their_type_are_refused_at_their_line(
    declaration: str, expected: str
) -> None:
    # They were kept (300 in an octet, 1.7 as 1, 2 as True) and encoding failed later on them.
    with pytest.raises(DefinitionError) as caught:
        _parse(_idl(declaration))
    assert str(caught.value) == f"msg/M.idl:7: {expected}"


@pytest.mark.parametrize(
    ("declaration", "default"),
    [
        ("@default (value=TRUE)\n      boolean b;", True),
        ("@default (value=0)\n      boolean b;", False),
        ("@default (value=1)\n      boolean b;", True),
        ("@default (value=255)\n      octet o;", 255),
        ("@default (value=-128)\n      int8 i;", -128),
        ("@default (value=-9223372036854775808)\n      int64 i;", -9223372036854775808),
        ("@default (value=1)\n      float f;", 1.0),
        ('@default (value="abc")\n      string<3> s;', "abc"),
        ('@default (value="(1, 2)")\n      int32__2 a;', (1, 2)),
        ('@default (value="[1]")\n      sequence<int32, 2> q;', (1,)),
        ('@default (value="(True, 0)")\n      sequence<boolean> q;', (True, False)),
    ],
)
def test_defaults_within_their_type_are_kept(declaration: str, default: DefaultValue) -> None:
    field = _parse(_idl(declaration)).messages[0].fields[1]
    assert field.default == default
    assert type(field.default) is type(default)


def test_constants_within_their_type_are_kept() -> None:
    constants = "const uint8 MAX = 255; const boolean ON = TRUE; const double ONE = 1;"
    parsed = _parse(_idl("int32 x;", constants))
    assert [(c.name, c.value) for c in parsed.messages[0].constants] == [
        ("MAX", 255),
        ("ON", True),
        ("ONE", 1.0),
    ]
