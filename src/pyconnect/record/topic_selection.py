"""Which topics of a bag a read takes: ``topics=`` and ``types=`` of ``open_bag``, checked.

With ``types=``, a read takes only the connections of a wanted type (``reads_connection``), as
rosbags' AnyReader does: of a topic recorded as ``Twist`` and as ``TwistStamped`` (two channels,
or merged bags), ``types=["geometry_msgs/msg/TwistStamped"]`` gives the ``TwistStamped`` ones,
and the topic's ``TopicInfo`` (type, count) and the count promised for the read say so too.
"""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Collection, Container, Iterable, Mapping, Sequence
from collections.abc import Set as AbstractSet
from pathlib import Path

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_files import BagFiles
from pyconnect.record.bag_info import BagInfo, TopicInfo
from pyconnect.record.bag_read_report import promised_count
from pyconnect.record.bag_storage import Connection, StorageFile
from pyconnect.record.topic_decoder import normalise_type_name

__all__ = [
    "TypedPart",
    "by_name",
    "left_out_note",
    "left_out_topics",
    "reads_connection",
    "select_topics",
    "selected_count",
    "types_by_topic",
    "wanted_types",
]


@dataclasses.dataclass(frozen=True)
class TypedPart:
    """What one connection of a storage file (or one entry of metadata.yaml, with no messages
    of its own: the files hold them) says of a topic: its type and its messages."""

    msg_type: str
    message_count: int = 0
    has_definition: bool = False
    type_hash: str = ""


def wanted_types(types: Iterable[str] | None) -> frozenset[str] | None:
    """``types=`` of ``open_bag`` normalised (``pkg/Name`` is ``pkg/msg/Name``); None: any."""
    if types is None:
        return None
    return frozenset(normalise_type_name(t) for t in ([types] if isinstance(types, str) else types))


def reads_connection(
    connection: Connection, topics: Container[str], types: AbstractSet[str] | None
) -> bool:
    """Whether a read of ``topics`` (``select_topics``) and ``types`` (``wanted_types``) takes
    ``connection``: a topic is selected when any of its types is wanted, but only its
    connections of a wanted type are read (the others' messages would decode as well, to
    values of a type nobody asked for)."""
    if connection.topic not in topics:
        return False
    return types is None or normalise_type_name(connection.msg_type) in types


def select_topics(
    info: BagInfo,
    path: Path,
    topics: Iterable[str] | None,
    types: Iterable[str] | None,
    *,
    raw: bool,
    topic_types: Mapping[str, Sequence[TypedPart]] | None = None,
) -> dict[str, TopicInfo]:
    """The selected topics by name (both given: a topic must match both).

    ``topic_types``: every type each topic has in the bags read together (``types_by_topic``);
    without it, the type ``info`` gives it (the first bag's, for merged bags). With ``types``,
    a topic that also has other types is described by its parts of the wanted types only
    (their type, count and hash), as only those are read.

    A topic the bag lacks raises ``BagError`` listing the bag's topics, and a type no topic of
    the bag has lists its types (a misspelt type would otherwise read nothing, silently); of
    several bags read together, the topics and types of any of them count. Unless ``raw``, a
    topic that cannot be decoded (not serialised as CDR, or of no type) raises when ``topics``
    or ``types`` selected it, and is left out when neither did (``left_out_topics`` says which):
    one such topic must not keep the others of the bag from being read.
    """
    known = by_name(info)
    chosen = dict(known)
    if topics is not None:
        wanted = [topics] if isinstance(topics, str) else list(topics)
        missing = [t for t in wanted if t not in known]
        if missing:
            listed = ", ".join(sorted(known)) or "none"
            raise BagError(f"{path}: no topic {', '.join(missing)} in this bag (topics: {listed})")
        chosen = {name: known[name] for name in wanted}
    taken = wanted_types(types)
    if taken is not None:
        each = _normalised(info, topic_types)
        _check_types(taken, each, path)
        chosen = {
            name: _narrowed(topic, (topic_types or {}).get(name, ()), taken)
            for name, topic in chosen.items()
            if each[name] & taken
        }
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


def by_name(info: BagInfo) -> dict[str, TopicInfo]:
    """Each topic of ``info`` once, as a read takes it (all its types): ``info`` lists a topic
    carried by two types twice, one entry per type. Its type is the first the bag declares
    (of those it names; ``types=`` narrows it, ``_narrowed``), its count that of every type."""
    found: dict[str, TopicInfo] = {}
    for topic in info.topics:
        first = found.get(topic.name)
        if first is None:
            found[topic.name] = topic
            continue
        found[topic.name] = dataclasses.replace(
            first,
            msg_type=first.msg_type or topic.msg_type,
            message_count=first.message_count + topic.message_count,
            has_definition=first.has_definition or topic.has_definition,
            type_hash=first.type_hash if first.msg_type else topic.type_hash,
            offered_qos_profiles=first.offered_qos_profiles or topic.offered_qos_profiles,
        )
    return found


def left_out_topics(
    info: BagInfo, topics: Iterable[str] | None, types: Iterable[str] | None, *, raw: bool
) -> dict[str, str]:
    """Topic -> why ``select_topics`` leaves it out of a read that selects no topics: the topics
    that cannot be decoded (none when ``raw``, or when ``topics`` or ``types`` select)."""
    if raw or topics is not None or types is not None:
        return {}
    found = {name: _undecodable(topic) for name, topic in by_name(info).items()}
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


def types_by_topic(
    bags: Iterable[tuple[BagFiles, Sequence[StorageFile]]],
) -> dict[str, list[TypedPart]]:
    """Topic -> what each connection (and metadata.yaml entry) of it in ``bags`` says, in their
    order: a topic recorded as two types in two bags (``Twist``, then ``TwistStamped``) has
    parts of both."""
    found: dict[str, list[TypedPart]] = {}
    for located, storages in bags:
        for storage in storages:
            counts = storage.message_counts()
            for connection in storage.connections():
                found.setdefault(connection.topic, []).append(
                    TypedPart(
                        connection.msg_type,
                        counts.get(connection.id, 0),
                        connection.definition is not None,
                        connection.type_hash,
                    )
                )
        for listed in located.metadata.topics if located.metadata is not None else ():
            part = TypedPart(listed.msg_type, type_hash=listed.type_description_hash)
            found.setdefault(listed.name, []).append(part)
    return found


def selected_count(
    bags: Sequence[tuple[BagFiles, Sequence[StorageFile]]],
    topics: Collection[str],
    types: AbstractSet[str] | None,
) -> int | None:
    """How many messages a read of ``topics`` and ``types`` (``wanted_types``) takes, as the
    metadata (or MCAP statistics) declare them (``promised_count``); None when some file does
    not say. A topic a bag also holds as another type is counted by its connections of the
    wanted types, from the files' statistics: metadata.yaml counts the topic as a whole."""
    if types is None:
        return promised_count(bags, topics)
    total = 0
    for located, storages in bags:
        taken = [
            (storage, connection)
            for storage in storages
            for connection in storage.connections()
            if connection.topic in topics
        ]
        mixed = {c.topic for _, c in taken if not reads_connection(c, topics, types)}
        whole = promised_count([(located, storages)], {t for t in topics if t not in mixed})
        if whole is None:
            return None
        total += whole
        for storage, connection in taken:
            if connection.topic not in mixed or not reads_connection(connection, topics, types):
                continue
            if getattr(storage, "promised", None) is None:
                return None
            total += storage.message_counts().get(connection.id, 0)
    return total


def _narrowed(topic: TopicInfo, parts: Sequence[TypedPart], wanted: AbstractSet[str]) -> TopicInfo:
    """``topic`` as its parts of the ``wanted`` types make it (as it is, when it has no other)."""
    kept = [part for part in parts if normalise_type_name(part.msg_type) in wanted]
    if not kept or len(kept) == len(parts):
        return topic
    return dataclasses.replace(
        topic,
        msg_type=kept[0].msg_type,
        message_count=sum(part.message_count for part in kept),
        has_definition=any(part.has_definition for part in kept),
        type_hash=next((part.type_hash for part in kept if part.type_hash), ""),
    )


def _normalised(
    info: BagInfo, topic_types: Mapping[str, Sequence[TypedPart]] | None
) -> dict[str, set[str]]:
    """Topic -> its types, normalised (``pkg/msg/Name``), for every topic of ``info``."""
    each: dict[str, set[str]] = {}
    for topic in info.topics:  # a topic of two types is two entries: each adds its type
        each.setdefault(topic.name, set()).add(normalise_type_name(topic.msg_type))
    for name, parts in (topic_types or {}).items():
        each.setdefault(name, set()).update(
            normalise_type_name(part.msg_type) for part in parts if part.msg_type
        )
    return each


def _check_types(wanted: AbstractSet[str], each: Mapping[str, set[str]], path: Path) -> None:
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
