"""ROS names without rclpy: rcl's and rmw's checks of node names, namespaces and topic names,
and rcl's expansion of ``~``, ``{node}``/``{ns}`` and relative names.

A peer must give its entities the names a ROS node would, or the two never meet: a peer
``vision`` in ``/robot1`` publishing ``~/status`` uses ``/robot1/vision/status``, as rclpy does.
pyconnect.transport imports no rclpy, so the rules are ported here; each function names the C
function it follows (ros2/rcl ``rcl/src/rcl/validate_topic_name.c``, ``expand_topic_name.c``;
ros2/rmw ``rmw/src/validate_full_topic_name.c``, ``validate_node_name.c``,
``validate_namespace.c``, Jazzy). tests/transport/test_ros_names.py holds rclpy's validators to
them. Remapping rules do not exist on a peer, so resolving is expanding then validating.
"""

from __future__ import annotations

from pyconnect.errors import PyconnectError

TOPIC_MAX_NAME_LENGTH = 255 - 8
"""rmw's RMW_TOPIC_MAX_NAME_LENGTH (room is left for a DDS prefix such as ``rt``)."""
NODE_NAME_MAX_LENGTH = 255
"""rmw's RMW_NODE_NAME_MAX_NAME_LENGTH."""
NAMESPACE_MAX_LENGTH = TOPIC_MAX_NAME_LENGTH - 2
"""rmw's RMW_NAMESPACE_MAX_NAME_LENGTH (a namespace leaves room for ``/`` and a name)."""

_DIGITS = frozenset("0123456789")
# rcutils_isalnum_no_locale: ASCII only, whatever the locale (str.isalnum would take 'é').
_ALNUM = frozenset("0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz")
_NODE_CHARS = _ALNUM | {"_"}
_FULL_NAME_CHARS = _NODE_CHARS | {"/"}
# rcl's built-in substitutions; rcl_expand_topic_name also takes a map of others, which rcl
# nodes pass empty (rcl_get_default_topic_name_substitutions), so any other one is an error.
_SUBSTITUTIONS = ("{node}", "{ns}", "{namespace}")
_SUBSTITUTION_CHARACTERS = (
    "must not contain characters other than alphanumerics or '_' in a substitution '{...}'"
)
_UNMATCHED_BRACE = "must not have unmatched curly braces '{' '}'"


class RosNameError(PyconnectError, ValueError):
    """A node name, namespace or topic/service/action name that ROS would refuse."""


def _at(rule: str, index: int) -> str:
    return f"{rule} (at index {index})"


def topic_name_problem(name: str) -> str | None:
    """Which of rcl's rules for a topic (service, action) name before expansion ``name``
    breaks, or None (rcl_validate_topic_name)."""
    if not name:
        return "must not be empty"
    if name[0] in _DIGITS:
        return _at("must not start with a number", 0)
    if name.endswith("/"):
        return _at("must not end with a forward slash", len(name) - 1)
    in_braces = False
    opening = 0
    for index, char in enumerate(name):
        if char in _ALNUM:
            if char in _DIGITS and in_braces and index - 1 == opening:
                return _at("must not start a substitution with a number", index)
        elif char == "_":
            pass
        elif char == "/":
            if in_braces:
                return _at(_SUBSTITUTION_CHARACTERS, index)
        elif char == "~":
            if index != 0:
                return _at("must not have a tilde '~' unless it is the first character", index)
        elif char == "{":
            opening = index
            if in_braces:
                return _at(_SUBSTITUTION_CHARACTERS, index)
            in_braces = True
        elif char == "}":
            if not in_braces:
                return _at(_UNMATCHED_BRACE, index)
            in_braces = False
        elif in_braces:
            return _at(_SUBSTITUTION_CHARACTERS, index)
        else:
            return _at(
                "must not contain characters other than alphanumerics, '_', '/', '~', '{' or '}'",
                index,
            )
    if in_braces:
        return _at(_UNMATCHED_BRACE, opening)
    # rcl checks "~x" only when a character follows the x (its loop stops one short of the
    # end), so rclpy accepts "~a" as "<ns>/<node>a": kept, so peers and nodes agree.
    for index in range(len(name) - 1):
        if name[index] == "/" and name[index + 1] in _DIGITS:
            return _at("must not have a token that starts with a number", index + 1)
        if index == 1 and name[0] == "~" and name[1] != "/":
            return _at("must not have a tilde '~' that is not followed by a '/'", 1)
    return None


def full_topic_name_problem(name: str) -> str | None:
    """Which of rmw's rules for a fully qualified (expanded) name ``name`` breaks, or None
    (rmw_validate_full_topic_name)."""
    if not name:
        return "must not be empty"
    if name[0] != "/":
        return _at("must be absolute, it must lead with a '/'", 0)
    if name.endswith("/"):
        return _at("must not end with a '/'", len(name) - 1)
    for index, char in enumerate(name):
        if char not in _FULL_NAME_CHARS:
            return _at("must not contain characters other than alphanumerics, '_' or '/'", index)
    for index in range(len(name) - 1):
        if name[index] == "/" and name[index + 1] == "/":
            return _at("must not contain repeated '/'", index + 1)
        if name[index] == "/" and name[index + 1] in _DIGITS:
            return _at("must not have a token that starts with a number", index + 1)
    if len(name) > TOPIC_MAX_NAME_LENGTH:
        return _too_long(TOPIC_MAX_NAME_LENGTH)
    return None


def node_name_problem(name: str) -> str | None:
    """Which of rmw's rules for a node name ``name`` breaks, or None (rmw_validate_node_name)."""
    if not name:
        return "must not be empty"
    for index, char in enumerate(name):
        if char not in _NODE_CHARS:
            return _at("must not contain characters other than alphanumerics or '_'", index)
    if name[0] in _DIGITS:
        return _at("must not start with a number", 0)
    if len(name) > NODE_NAME_MAX_LENGTH:
        return _too_long(NODE_NAME_MAX_LENGTH)
    return None


def namespace_problem(namespace: str) -> str | None:
    """Which of rmw's rules for a namespace (already ``/``-rooted, as rcl_node_init makes it)
    ``namespace`` breaks, or None (rmw_validate_namespace: ``/``, or a full name that is
    short enough to leave room for a node name)."""
    if namespace == "/":
        return None
    problem = full_topic_name_problem(namespace)
    if problem is not None and problem != _too_long(TOPIC_MAX_NAME_LENGTH):
        return problem
    if len(namespace) > NAMESPACE_MAX_LENGTH:
        return _too_long(NAMESPACE_MAX_LENGTH)
    return None


def _too_long(limit: int) -> str:
    return _at(f"must not be longer than {limit} characters", limit - 1)


def expand_topic_name(name: str, node_name: str, namespace: str, kind: str = "topic") -> str:
    """``name`` made absolute as rcl_expand_topic_name does: ``~`` is ``<namespace>/<node>``,
    ``{node}``, ``{ns}``/``{namespace}`` are substituted, a relative name goes under
    ``namespace``. Raises ``RosNameError`` (``kind`` words it: topic, service, action) for an
    invalid name, node name or namespace; the result may still break
    ``full_topic_name_problem`` (``a//b`` expands)."""
    for what, value, problem in (
        (f"{kind} name", name, topic_name_problem(name)),
        ("node name", node_name, node_name_problem(node_name)),
        ("namespace", namespace, namespace_problem(namespace)),
    ):
        if problem is not None:
            raise RosNameError(f"{what} {value!r} {problem}")
    if name.startswith("/") and "{" not in name:
        return name
    separator = "" if namespace == "/" else "/"
    expanded = name
    if name.startswith("~"):
        expanded = f"{namespace}{separator}{node_name}{name[1:]}"
    while "{" in expanded:
        # Validation left balanced, unnested, non-empty braces; replacements have none.
        start = expanded.index("{")
        substitution = expanded[start : expanded.index("}") + 1]
        if substitution not in _SUBSTITUTIONS:
            raise RosNameError(
                f"{kind} name {name!r} has an unknown substitution {substitution}; expected "
                f"one of {', '.join(_SUBSTITUTIONS)}"
            )
        replacement = node_name if substitution == "{node}" else namespace
        expanded = expanded.replace(substitution, replacement)
    if not expanded.startswith("/"):
        expanded = f"{namespace}{separator}{expanded}"
    return expanded


def resolve_name(name: str, node_name: str, namespace: str, kind: str = "topic") -> str:
    """The fully qualified name a node ``node_name`` in ``namespace`` uses for ``name``
    (rcl_node_resolve_name without remapping): expanded, then checked as a full name."""
    expanded = expand_topic_name(name, node_name, namespace, kind)
    problem = full_topic_name_problem(expanded)
    if problem is not None:
        raise RosNameError(f"{kind} name {name!r} expands to {expanded!r}, which {problem}")
    return expanded
