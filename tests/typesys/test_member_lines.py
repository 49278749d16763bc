"""Finding the line that declares a field or constant: in its own message's part of the file,
never in an IDL annotation, comment or string."""

from __future__ import annotations

import pytest

from pyconnect.typesys.member_lines import line_declaring, rendered_member_at

_IDL = """module p {
  module srv {
    module S_Request_Constants {
      const int32 X = 1;  // x; in a comment
    };
    struct S_Request {
      @default (value=1)
      @verbatim (language="comment", text=
        "int32 value;" "x;")
      int32 x;
    };
    /* int32 value; */
    struct S_Response {
      @default (value=2)
      int32 x;
      @unit (value="m")
      float value;
    };
  };
};
"""


@pytest.mark.parametrize(
    ("member", "message", "line"),
    [
        ("x", "S_Request", 10),
        ("x", "S_Response", 15),
        ("x", None, 10),
        ("value", "S_Response", 17),
        ("value", None, 17),
        ("X", "S_Request", 4),
        ("X", "S_Response", None),
        ("x", "Unknown", 10),  # a message not found: the whole text
    ],
)
def test_idl_lines_are_searched_in_the_messages_struct_and_constants(
    member: str, message: str | None, line: int | None
) -> None:
    assert line_declaring(_IDL, member, idl=True, message=message) == line


_ACTION = "float32 speed\n---\n# speed\nbool ok\n---\nfloat32 speed nan\nint8 SPEED=1\n"


@pytest.mark.parametrize(
    ("member", "message", "line"),
    [
        ("speed", "A_Goal", 1),
        ("speed", "A_Result", None),
        ("speed", "A_Feedback", 6),
        ("SPEED", "A_Feedback", 7),
        ("speed", None, 1),
        ("speed", "A_SendGoal_Request", 1),  # an implicit message: the whole text
    ],
)
def test_msg_lines_are_searched_in_the_messages_part(
    member: str, message: str | None, line: int | None
) -> None:
    assert line_declaring(_ACTION, member, idl=False, message=message) == line


def test_the_member_rosidl_parser_stopped_at_in_rendered_idl() -> None:
    rendered = (
        "module p {\n  module msg {\n    module M_Constants {\n"
        '      const string S = "a\\";\n    };\n    struct M {\n      int32 a;\n\n'
        '      @default (value="\\")\n      string s;\n    };\n  };\n};\n'
    )
    assert rendered_member_at(rendered, 4) == ("M", "S")
    assert rendered_member_at(rendered, 9) == ("M", "s")
    assert rendered_member_at(rendered, 11) is None
    assert rendered_member_at(rendered, -1) is None  # lark's line for an unexpected end
