"""Which topics of a bag a read takes: ``topics=`` and ``types=`` of ``open_bag``, checked."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_info import BagInfo, TopicInfo
from pyconnect.record.topic_decoder import normalise_type_name

__all__ = ["select_topics"]


def select_topics(
    info: BagInfo,
    path: Path,
    topics: Iterable[str] | None,
    types: Iterable[str] | None,
    *,
    raw: bool,
) -> dict[str, TopicInfo]:
    """The selected topics by name (both given: a topic must match both).

    A topic the bag lacks raises ``BagError`` listing the bag's topics; unless ``raw``, so does a
    selected topic that is not serialised as CDR (it could not be decoded).
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
        chosen = {
            name: topic
            for name, topic in chosen.items()
            if normalise_type_name(topic.msg_type) in wanted_types
        }
    if not raw:
        for topic in chosen.values():
            if topic.serialization_format != "cdr":
                raise BagError(
                    f"{path}: topic {topic.name} is serialised as "
                    f"{topic.serialization_format!r}; only 'cdr' can be decoded "
                    "(raw=True reads it undecoded)"
                )
    return chosen
