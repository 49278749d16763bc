"""Which topics of a bag a read takes: ``topics=`` and ``types=`` of ``open_bag``, checked."""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping, Sequence
from collections.abc import Set as AbstractSet
from pathlib import Path

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_files import BagFiles
from pyconnect.record.bag_info import BagInfo, TopicInfo
from pyconnect.record.bag_storage import StorageFile
from pyconnect.record.topic_decoder import normalise_type_name

__all__ = ["left_out_note", "left_out_topics", "select_topics", "types_by_topic"]


def select_topics(
    info: BagInfo,
    path: Path,
    topics: Iterable[str] | None,
    types: Iterable[str] | None,
    *,
    raw: bool,
    topic_types: Mapping[str, AbstractSet[str]] | None = None,
) -> dict[str, TopicInfo]:
    """The selected topics by name (both given: a topic must match both).

    ``topic_types``: every type each topic has in the bags read together (``types_by_topic``);
    without it, the type ``info`` gives it (the first bag's, for merged bags).

    A topic the bag lacks raises ``BagError`` listing the bag's topics, and a type no topic of
    the bag has lists its types (a misspelt type would otherwise read nothing, silently); of
    several bags read together, the topics and types of any of them count. Unless ``raw``, a
    topic that cannot be decoded (not serialised as CDR, or of no type) raises when ``topics``
    or ``types`` selected it, and is left out when neither did (``left_out_topics`` says which):
    one such topic must not keep the others of the bag from being read.
    """
    known = {topic.name: topic for topic in info.topics}
    chosen = dict(known)
    if topics is not None:
        wanted = [topics] if isinstance(topics, str) else list(topics)
        missing = [t for t in wanted if t not in known]
        if missing:
            listed = ", ".join(sorted(known)) or "none"
            raise BagError(f"{path}: no topic {', '.join(missing)} in this bag (topics: {listed})")
        chosen = {name: known[name] for name in wanted}
    if types is not None:
        wanted_types = {
            normalise_type_name(t) for t in ([types] if isinstance(types, str) else types)
        }
        each = _normalised(info, topic_types)
        _check_types(wanted_types, each, path)
        chosen = {name: topic for name, topic in chosen.items() if each[name] & wanted_types}
    if raw:
        return chosen
    if topics is None and types is None:
        return {name: topic for name, topic in chosen.items() if _undecodable(topic) is None}
    for topic in chosen.values():
        if topic.serialization_format != "cdr":
            raise BagError(
                f"{path}: topic {topic.name} is serialised as "
                f"{topic.serialization_format!r}; only 'cdr' can be decoded "
                "(raw=True reads it undecoded)"
            )
        if not topic.msg_type:
            raise BagError(
                f"{path}: topic {topic.name} has no type (its channel has no schema); "
                "raw=True reads it undecoded"
            )
    return chosen


def left_out_topics(
    info: BagInfo, topics: Iterable[str] | None, types: Iterable[str] | None, *, raw: bool
) -> dict[str, str]:
    """Topic -> why ``select_topics`` leaves it out of a read that selects no topics: the topics
    that cannot be decoded (none when ``raw``, or when ``topics`` or ``types`` select)."""
    if raw or topics is not None or types is not None:
        return {}
    found = {topic.name: _undecodable(topic) for topic in info.topics}
    return {name: why for name, why in found.items() if why is not None}


def left_out_note(path: Path, left_out: Mapping[str, str]) -> str:
    """One line saying which topics a read left out (``left_out_topics``) and why."""
    each = ", ".join(f"{name} ({why})" for name, why in sorted(left_out.items()))
    return (
        f"{path}: {len(left_out)} topic(s) not read, as only 'cdr' topics of a known type can "
        f"be decoded: {each}; select one with raw=True to read it undecoded"
    )


def _undecodable(topic: TopicInfo) -> str | None:
    """Why no message of ``topic`` can be decoded, in a few words (None: they can be)."""
    if topic.serialization_format != "cdr":
        return f"serialised as {topic.serialization_format!r}"
    if not topic.msg_type:
        # An MCAP channel with schema 0: there is neither a stored nor an installed type.
        return "no type: its channel has no schema"
    return None


def types_by_topic(bags: Iterable[tuple[BagFiles, Sequence[StorageFile]]]) -> dict[str, set[str]]:
    """Topic -> every type it has in ``bags`` (their storage files and metadata.yaml files):
    a topic recorded as two types in two bags (``Twist``, then ``TwistStamped``) has both."""
    found: dict[str, set[str]] = {}
    for located, storages in bags:
        for storage in storages:
            for connection in storage.connections():
                found.setdefault(connection.topic, set()).add(connection.msg_type)
        for listed in located.metadata.topics if located.metadata is not None else ():
            found.setdefault(listed.name, set()).add(listed.msg_type)
    return found


def _normalised(
    info: BagInfo, topic_types: Mapping[str, AbstractSet[str]] | None
) -> dict[str, set[str]]:
    """Topic -> its types, normalised (``pkg/msg/Name``), for every topic of ``info``."""
    each = {topic.name: {normalise_type_name(topic.msg_type)} for topic in info.topics}
    for name, found in (topic_types or {}).items():
        each.setdefault(name, set()).update(normalise_type_name(t) for t in found if t)
    return each


def _check_types(wanted: set[str], each: Mapping[str, set[str]], path: Path) -> None:
    present = set().union(*each.values()) - {""}
    missing = sorted(wanted - present)
    if not missing:
        return
    listed = ", ".join(sorted(present)) or "none"
    hints = [hint for name in missing for hint in _close_types(name, present)]
    hint = f"; did you mean {', '.join(hints)}?" if hints else ""
    raise BagError(
        f"{path}: no topic of type {', '.join(missing)} in this bag (types: {listed}){hint}"
    )


def _close_types(name: str, present: set[str]) -> list[str]:
    """Types of the bag ``name`` may have meant: close in spelling, or of the same short name
    (``Odometry``, ``nav_msgs.msg.Odometry`` for ``nav_msgs/msg/Odometry``)."""
    short = name.replace(".", "/").rsplit("/", 1)[-1]
    same_short = [t for t in sorted(present) if t.rsplit("/", 1)[-1] == short]
    # Types share "_msgs/msg/", which lifts every ratio: only a near-identical one is a hint.
    close = difflib.get_close_matches(name, sorted(present), n=1, cutoff=0.8)
    return list(dict.fromkeys([*same_short, *close]))
