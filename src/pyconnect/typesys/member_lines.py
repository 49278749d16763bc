"""Find the line of .msg/.srv/.action/.idl text that declares a field or constant, in its part.

rosidl's parsers and the type model name the member at fault but not its line; these searches
read the text the way a person does: a .srv/.action holds one message per `---` separated part,
an .idl file one struct (and its ``<Name>_Constants`` module) per message, and an IDL annotation
(``@default (value=1)``) declares nothing.
"""

from __future__ import annotations

import re

# The messages a .msg/.srv/.action holds, in order, as rosidl names them after the file's stem;
# a .srv/.action separates them with lines that are exactly `---`.
SECTION_SUFFIXES = {".msg": ("",), ".srv": ("_Request", "_Response"),
                    ".action": ("_Goal", "_Result", "_Feedback")}  # fmt: skip
SECTION_SEPARATOR = "---"


def sections(lines: list[str], suffix: str) -> list[tuple[str, int, int]] | None:
    """(message suffix, first line index, end index) of each message of a ``suffix`` file; None
    when its `---` separators are not the ones it needs. A .msg is one part whatever it holds:
    rosidl's message parser is the one to complain about a `---` there."""
    suffixes = SECTION_SUFFIXES[suffix]
    separators = [n for n, line in enumerate(lines) if line == SECTION_SEPARATOR]
    if suffix == ".msg":
        separators = []
    if len(separators) != len(suffixes) - 1:
        return None
    starts = [0, *(n + 1 for n in separators)]
    stops = [*separators, len(lines)]
    return list(zip(suffixes, starts, stops, strict=True))


def line_declaring(text: str, member: str, *, idl: bool, message: str | None = None) -> int | None:
    """The first line that declares the field or constant ``member`` (None if none is found).

    ``message``, rosidl's name of the message holding it (``Same_Request``, ``Same_Goal``),
    narrows the search to that message's part of a .srv/.action, or to its struct and constants
    module in IDL: a name may be declared by several messages of one file.
    """
    lines = _idl_code(text) if idl else [line.split("#", 1)[0] for line in text.splitlines()]
    name = re.escape(member)
    # .msg: `type name [default]` or `type NAME=value`; IDL: `type name;`, `type name[2];`,
    # `const type NAME = v;`
    idl_pattern = rf"\b{name}\s*(\[[^\]]*\]\s*)*[=;]"
    pattern = re.compile(idl_pattern if idl else rf"^\s*\S+\s+{name}(\s|=|$)")
    for start, stop in _scopes(lines, message, idl=idl):
        for number in range(start, stop):
            if pattern.search(lines[number]):
                return number + 1
    return None


def _scopes(lines: list[str], message: str | None, *, idl: bool) -> list[tuple[int, int]]:
    """The line ranges holding ``message``'s members; the whole text when it cannot tell."""
    everything = [(0, len(lines))]
    if message is None:
        return everything
    if idl:
        scopes = []
        name = re.escape(message)
        opener = re.compile(rf"\b(struct\s+{name}|module\s+{name}_Constants)\b")
        for number, line in enumerate(lines):
            if opener.search(line):
                # Struct and constants module bodies hold no braces: the first `}` closes them.
                ends = (n + 1 for n in range(number, len(lines)) if "}" in lines[n])
                scopes.append((number, next(ends, len(lines))))
        return scopes or everything
    for kind in (".srv", ".action"):
        for suffix, start, stop in sections(lines, kind) or ():
            if message.endswith(suffix):
                return [(start, stop)]
    return everything


# What declares nothing in IDL: string and character literals, comments and annotations (with
# their arguments, which may span lines). Literals go first so that `"//"` is not a comment.
_LITERAL_OR_COMMENT = re.compile(
    r"\"(?:[^\"\\\n]|\\.)*\"|'(?:[^'\\\n]|\\.)*'|//[^\n]*|/\*.*?\*/", re.DOTALL
)
_ANNOTATION = re.compile(r"@\w+(?:::\w+)*(?:\s*\([^()]*\))?")


def _idl_code(text: str) -> list[str]:
    """``text``'s lines with what declares nothing blanked out (line numbers are kept)."""

    def blank(match: re.Match[str]) -> str:
        return "\n" * match.group().count("\n")

    code = _ANNOTATION.sub(blank, _LITERAL_OR_COMMENT.sub(blank, text))
    return code.split("\n")


# A member declaration of the IDL rosidl_adapter writes: `int32 a;`, `const string S = "x";`.
_RENDERED_DECLARATION = re.compile(r"^\s*(?:const\s+\S+\s+(\w+)\s*=.*|[\w:<>, ]+\s(\w+));\s*$")
_RENDERED_SCOPE = re.compile(r"^\s*(?:struct\s+(\w+)|module\s+(\w+)_Constants)\b")


def rendered_member_at(idl_text: str, line: int) -> tuple[str, str] | None:
    """(message, member) whose declaration in IDL that rosidl_adapter wrote holds line ``line``
    (1-based) or follows it, as annotations precede their member; None if none does."""
    lines = idl_text.splitlines()
    if not 1 <= line <= len(lines):  # lark gives -1 for an unexpected end
        return None
    member = None
    for number in range(line - 1, len(lines)):
        found = _RENDERED_DECLARATION.match(lines[number])
        if found:
            member = found.group(1) or found.group(2)
            break
    if member is None:
        return None
    for number in range(line - 1, -1, -1):
        scope = _RENDERED_SCOPE.match(lines[number])
        if scope:
            return scope.group(1) or scope.group(2), member
    return None
