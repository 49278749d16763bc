"""The definition text rosbag2 stores for an installed type, written from its interface files.

The ``ros2msg`` layout rosbag2 (Jazzy) writes: the main type's ``.msg`` text first; then, for
every type it depends on (each text's dependencies in sorted order, depth first, each once), a
newline, a line of 80 ``=``, a line ``MSG: pkg/Name`` and that type's ``.msg`` text. A type
that has, or nests one that has, no ``.msg`` file is written as ``ros2idl``: one block per
type, the main type's first, each headed by the separator and ``IDL: pkg/msg/Name``, the
dependencies being the files an ``.idl`` includes. A service event type (``pkg/srv/Name_Event``)
is written as rosbag2 Jazzy writes it, a block headed ``SRV: pkg/srv/Name`` holding the ``.srv``
text and then its dependencies (see ``_service_text``); an action part
(``pkg/action/Name_FeedbackMessage``...) in its ``.msg`` form (see ``_action_part_text``).
Files are stored byte for byte, their line ends (CRLF) kept, as rosbag2's ``std::ifstream`` reads.
``pyconnect.typesys.definition_text`` reads such texts back.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

from pyconnect.errors import CodecNotFoundError
from pyconnect.typesys.names import parse_type_name, split_part
from pyconnect.typesys.packages import installed_share_dirs
from pyconnect.typesys.primitives import MSG_BUILTIN_NAMES

__all__ = [
    "DEFINITION_SEPARATOR",
    "definition_encoding",
    "dependencies_of",
    "installed_definition",
    "interface_file",
]

DEFINITION_SEPARATOR = "=" * 80


def interface_file(package: str, namespace: str, name: str, extension: str = "") -> Path:
    """The installed ``.msg``/``.srv``/``.action`` file of a type (``CodecNotFoundError``);
    ``extension="idl"`` asks for its ``.idl`` file instead."""
    share = installed_share_dirs().get(package)
    if share is None:
        raise CodecNotFoundError(
            f"{package}/{namespace}/{name}: package {package!r} is not installed"
        )
    path = share / namespace / f"{name}.{extension or namespace}"
    if not path.is_file():
        raise CodecNotFoundError(f"{package}/{namespace}/{name}: no {path.name} in {share}")
    return path


def _base_type(field_type: str, package: str) -> str | None:
    """``pkg/Name`` of a field type that is a message, None for primitives."""
    base = field_type.split("[", 1)[0]
    base = base.split("<=", 1)[0]
    if base in MSG_BUILTIN_NAMES:
        return None
    if "/" not in base:
        return f"{package}/{base}"
    parts = base.split("/")
    return f"{parts[0]}/{parts[-1]}"


def dependencies_of(text: str, package: str) -> list[str]:
    """The message types (``pkg/Name``) that fields of a ``.msg``/``.srv`` text refer to."""
    found: list[str] = []
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#") or line == "---":
            continue
        tokens = line.split(None, 2)
        if len(tokens) < 2 or "=" in tokens[1] or (len(tokens) > 2 and tokens[2].startswith("=")):
            continue  # a constant: its type is always primitive
        dependency = _base_type(tokens[0], package)
        if dependency is not None and dependency not in found:
            found.append(dependency)
    return found


# `#include "pkg/msg/Name.idl"` (or <...>): what an .idl file depends on, as rosbag2 finds it.
_IDL_INCLUDE = re.compile(r'^#include\s+["<]([A-Za-z0-9_/]+)\.idl[">]', re.MULTILINE)


def definition_encoding(text: str) -> str:
    """``ros2idl`` for a text laid out as ``installed_definition`` writes IDL, else ``ros2msg``."""
    if text.startswith(f"{DEFINITION_SEPARATOR}\nIDL: "):
        return "ros2idl"
    # rosbag2 Jazzy labels a service's text by the format of the last dependency it wrote, and
    # "unknown" when the service has none (no reader then uses the text, rosbags refuses the
    # bag); here such a text is ros2msg, and ros2idl once it holds an .idl text.
    if text.startswith(f"{DEFINITION_SEPARATOR}\nSRV: "):
        return "ros2idl" if f"\n{DEFINITION_SEPARATOR}\nIDL: " in text else "ros2msg"
    return "ros2msg"


@functools.lru_cache(maxsize=512)
def installed_definition(msg_type: str) -> str:
    """The definition text rosbag2 stores for an installed message type (``ros2msg``, or
    ``ros2idl`` when a type involved has only an ``.idl`` file: ``definition_encoding`` tells),
    a service event (see ``_service_text``) or an action part (see ``_action_part_text``)."""
    parsed = parse_type_name(msg_type)
    namespace = parsed.namespace or "msg"
    if namespace == "srv" and parsed.name.endswith("_Event"):
        return _service_text(parsed.package, parsed.name[: -len("_Event")])
    if namespace == "action":
        return _action_part_text(parsed.package, parsed.name)
    if namespace != "msg":
        raise CodecNotFoundError(
            f"{msg_type}: only messages, service events and action parts have a definition text"
        )
    try:
        return _msg_text_with_dependencies(parsed.package, _msg_text(parsed.package, parsed.name))
    except CodecNotFoundError as no_msg:
        # As rosbag2 does: a type that has (or nests one that has) no .msg file is stored as IDL.
        try:
            return _idl_text_with_dependencies(f"{parsed.package}/msg/{parsed.name}")
        except CodecNotFoundError:
            raise no_msg from None


def _file_text(path: Path) -> str:
    """A file's text as rosbag2 stores it: read as bytes (std::ifstream), its line ends kept."""
    return path.read_bytes().decode("utf-8")


def _msg_text(package: str, name: str) -> str:
    return _file_text(interface_file(package, "msg", name))


def _msg_text_with_dependencies(package: str, main: str, seen: set[str] | None = None) -> str:
    """rosbag2 Jazzy's layout: after a text, each type it depends on that was not written yet,
    in sorted order (a std::set), as a newline, the separator, ``MSG: pkg/Name`` and its text,
    itself followed by its own dependencies (depth first)."""
    seen = set() if seen is None else seen
    definition = main
    for dependency in sorted(dependencies_of(main, package)):
        if dependency in seen:
            continue
        seen.add(dependency)
        dep_package, dep_name = dependency.split("/")
        text = _msg_text(dep_package, dep_name)
        definition += f"\n{DEFINITION_SEPARATOR}\nMSG: {dependency}\n"
        definition += _msg_text_with_dependencies(dep_package, text, seen)
    return definition


def _idl_text_with_dependencies(full_name: str) -> str:
    """rosbag2's ``ros2idl`` layout: every block, the main type's first, is headed by the
    separator and ``IDL: pkg/msg/Name``; the dependencies are the files it ``#include``s."""
    return f"{DEFINITION_SEPARATOR}\nIDL: {full_name}\n" + _idl_with_includes(full_name, set())


def _idl_with_includes(type_name: str, seen: set[str]) -> str:
    """An .idl text, then each file it includes that ``seen`` lacks (added), depth first."""
    package, *_, name = type_name.split("/")
    text = _file_text(interface_file(package, "msg", name, "idl"))
    for dependency in sorted(set(_IDL_INCLUDE.findall(text))):
        if dependency in seen:
            continue
        seen.add(dependency)
        text += f"\n{DEFINITION_SEPARATOR}\nIDL: {dependency}\n"
        text += _idl_with_includes(dependency, seen)
    return text


def _service_text(package: str, service: str) -> str:
    """The text rosbag2 Jazzy stores for a service's events (``pkg/srv/Name_Event``).

    Every rosbag2 0.26 release (LocalMessageDefinitionSource::get_full_text, its ``/srv/``
    branch) writes the separator, ``SRV: pkg/srv/Name``, the raw .srv text, then each message
    type it depends on as ``get_full_text`` writes a message's: self-sufficient but for
    service_msgs/ServiceEventInfo, which no .srv names. The raw .srv text alone, which some of
    rosbag2's own test bags hold, came from a development build of that feature (those bags
    also file it under the service's name): readers take both. A dependency with no .msg file
    is written as rosbag2 does, its ``MSG:`` line left without a text and then its .idl text
    headed ``IDL: pkg/Name``.
    """
    root = f"{package}/srv/{service}"
    text = _file_text(interface_file(package, "srv", service))
    definition = f"{DEFINITION_SEPARATOR}\nSRV: {root}\n{text}"
    seen: set[str] = set()  # rosbag2 shares one set of (type, format): these are .msg types
    seen_idl: set[str] = set()
    for dependency in sorted(dependencies_of(text, package)):
        if dependency in seen:
            continue
        seen.add(dependency)
        definition += f"\n{DEFINITION_SEPARATOR}\nMSG: {dependency}\n"
        try:
            dep_package, dep_name = dependency.split("/")
            dep_text = _msg_text(dep_package, dep_name)
            definition += _msg_text_with_dependencies(dep_package, dep_text, seen)
        except CodecNotFoundError:
            if dependency in seen_idl:
                continue
            seen_idl.add(dependency)
            definition += f"\n{DEFINITION_SEPARATOR}\nIDL: {dependency}\n"
            definition += _idl_with_includes(dependency, seen_idl)
    return definition


# The implicit message types of an action, in .msg form (``{I}`` is the action's name).
_ACTION_PART_TEXTS = {
    "FeedbackMessage": "unique_identifier_msgs/UUID goal_id\n{I}_Feedback feedback\n",
    "SendGoal_Request": "unique_identifier_msgs/UUID goal_id\n{I}_Goal goal\n",
    "SendGoal_Response": "bool accepted\nbuiltin_interfaces/Time stamp\n",
    "GetResult_Request": "unique_identifier_msgs/UUID goal_id\n",
    "GetResult_Response": "int8 status\n{I}_Result result\n",
    "SendGoal_Event": "service_msgs/ServiceEventInfo info\n"
    "{I}_SendGoal_Request[<=1] request\n{I}_SendGoal_Response[<=1] response\n",
    "GetResult_Event": "service_msgs/ServiceEventInfo info\n"
    "{I}_GetResult_Request[<=1] request\n{I}_GetResult_Response[<=1] response\n",
}
_ACTION_SECTIONS = ("Goal", "Result", "Feedback")


def _action_part_text(package: str, name: str) -> str:
    """``ros2msg`` text of an action part (``pkg/action/Fibonacci_FeedbackMessage``...).

    rosbag2 Jazzy stores none for these (encoding ``unknown``, which rosbags cannot open);
    this text is the part's fields in .msg form with its dependencies as ``MSG:`` blocks, the
    action's own parts named ``pkg/action/Name`` and every other message type qualified with
    its package, so that a reader resolving names by the enclosing block's namespace (rosbags)
    finds each one.
    """
    part = split_part("action", name)
    if part is None:
        raise CodecNotFoundError(f"{package}/action/{name}: not a part of an action")
    interface = part[0]
    action_text = _file_text(interface_file(package, "action", interface))
    sections = re.split(r"^---[ \t]*\r?$\n?", action_text, flags=re.MULTILINE)
    texts = {suffix: text for suffix, text in zip(_ACTION_SECTIONS, sections, strict=False)}
    texts.update({s: t.format(I=interface) for s, t in _ACTION_PART_TEXTS.items()})
    own = {f"{package}/{interface}_{suffix}": suffix for suffix in texts}
    seen: set[str] = set()

    def with_dependencies(text: str) -> str:
        definition = _qualified(text, package, own)
        for dependency in sorted(dependencies_of(text, package)):
            if dependency in seen:
                continue
            seen.add(dependency)
            if dependency in own:
                header = f"{package}/action/{dependency.split('/')[1]}"
                definition += f"\n{DEFINITION_SEPARATOR}\nMSG: {header}\n"
                definition += with_dependencies(texts[own[dependency]])
            else:
                dep_package, dep_name = dependency.split("/")
                definition += f"\n{DEFINITION_SEPARATOR}\nMSG: {dependency}\n"
                dep_text = _msg_text(dep_package, dep_name)
                definition += _msg_text_with_dependencies(dep_package, dep_text, seen)
        return definition

    suffix = part[1]
    if suffix not in texts:
        raise CodecNotFoundError(f"{package}/action/{name}: no such part of an action")
    return with_dependencies(texts[suffix])


_FIELD_TYPE = re.compile(r"^(\s*)([A-Za-z][A-Za-z0-9_/]*)(?=[\s\[<])")


def _qualified(text: str, package: str, own: dict[str, str]) -> str:
    """``text`` with each message field type spelled in full: ``pkg/Name``, or
    ``pkg/action/Name`` for the action's own parts (a bare ``Name`` in an .action file means
    ``pkg/msg/Name``; a reader of a ``pkg/action/...`` block would look in ``action``)."""
    lines = []
    for line in text.splitlines(keepends=True):
        dependency = dependencies_of(line, package)
        match = _FIELD_TYPE.match(line)
        if not (dependency and match):
            lines.append(line)
            continue
        full = dependency[0]
        if full in own:
            full = f"{package}/action/{full.split('/')[1]}"
        lines.append(match.group(1) + full + line[match.end(2) :])
    return "".join(lines)
