"""rosbag2 ``metadata.yaml``: read every version (4-9) and write the one we record (8)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from pyconnect.record.bag_errors import BagError

__all__ = [
    "METADATA_FILE",
    "BagMetadata",
    "TopicMetadata",
    "list_item_yaml",
    "metadata_info",
    "metadata_yaml",
    "read_metadata",
    "write_metadata",
]

METADATA_FILE = "metadata.yaml"
WRITTEN_VERSION = 8
_ROOT = "rosbag2_bagfile_information"


@dataclass(frozen=True)
class TopicMetadata:
    """One topic as metadata.yaml lists it."""

    name: str
    msg_type: str
    serialization_format: str = "cdr"
    offered_qos_profiles: str = ""
    type_description_hash: str = ""
    message_count: int = 0


@dataclass(frozen=True)
class BagMetadata:
    """The parts of metadata.yaml that reading needs, and that recording writes."""

    storage_identifier: str
    relative_file_paths: tuple[str, ...]
    topics: tuple[TopicMetadata, ...] = ()
    starting_time_ns: int = 0
    duration_ns: int = 0
    message_count: int = 0
    compression_format: str = ""
    compression_mode: str = ""
    version: int = WRITTEN_VERSION
    files: tuple[dict[str, Any], ...] = field(default=())


def _qos_text(value: object) -> str:
    # Up to v8 the profiles are one YAML string; v9 writers may store a list instead.
    if value is None:
        return ""
    if isinstance(value, str):
        return value
    return yaml.safe_dump(value, sort_keys=False) if value else ""


def _topic(entry: dict[str, Any]) -> TopicMetadata:
    topic = entry["topic_metadata"]
    return TopicMetadata(
        name=str(topic["name"]),
        msg_type=str(topic["type"]),
        serialization_format=str(topic.get("serialization_format", "")),
        offered_qos_profiles=_qos_text(topic.get("offered_qos_profiles")),
        type_description_hash=str(topic.get("type_description_hash", "") or ""),
        message_count=int(entry.get("message_count", 0) or 0),
    )


def read_metadata(path: Path) -> BagMetadata:
    """Parse a metadata.yaml; ``BagError`` names the file and what is wrong."""
    try:
        document = yaml.safe_load(path.read_text(encoding="utf-8"))
        info = document[_ROOT]
        files = tuple(info.get("files") or ())
        relative = info.get("relative_file_paths") or [entry["path"] for entry in files]
        starting = info.get("starting_time") or {}
        duration = info.get("duration") or {}
        return BagMetadata(
            storage_identifier=str(info.get("storage_identifier", "") or ""),
            relative_file_paths=tuple(str(p) for p in relative),
            topics=tuple(_topic(entry) for entry in info.get("topics_with_message_count") or ()),
            starting_time_ns=int(starting.get("nanoseconds_since_epoch", 0)),
            duration_ns=int(duration.get("nanoseconds", 0)),
            message_count=int(info.get("message_count", 0) or 0),
            compression_format=str(info.get("compression_format", "") or ""),
            compression_mode=str(info.get("compression_mode", "") or ""),
            version=int(info.get("version", 0) or 0),
            files=files,
        )
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError, AttributeError) as error:
        kind = type(error).__name__
        raise BagError(f"{path}: not a rosbag2 metadata file ({kind}: {error})") from None


def metadata_info(metadata: BagMetadata) -> dict[str, Any]:
    """``metadata`` as version 8's ``rosbag2_bagfile_information`` mapping: metadata.yaml's
    content, and what rosbag2 stores in an MCAP file's "rosbag2" metadata record."""
    return {
        "version": WRITTEN_VERSION,
        "storage_identifier": metadata.storage_identifier,
        "duration": {"nanoseconds": metadata.duration_ns},
        "starting_time": {"nanoseconds_since_epoch": metadata.starting_time_ns},
        "message_count": metadata.message_count,
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": topic.name,
                    "type": topic.msg_type,
                    "serialization_format": topic.serialization_format,
                    "offered_qos_profiles": topic.offered_qos_profiles,
                    "type_description_hash": topic.type_description_hash,
                },
                "message_count": topic.message_count,
            }
            for topic in metadata.topics
        ],
        "compression_format": metadata.compression_format,
        "compression_mode": metadata.compression_mode,
        "relative_file_paths": list(metadata.relative_file_paths),
        "files": [dict(entry) for entry in metadata.files],
        "custom_data": {},
        "ros_distro": "jazzy",
    }


def metadata_yaml(info: dict[str, Any]) -> str:
    """YAML text of a mapping, written as rosbag2 writes its metadata."""
    # libyaml's emitter when PyYAML has it: the same text, several times faster (the
    # representer, most of the cost, is Python either way).
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
    return str(yaml.dump(info, Dumper=dumper, sort_keys=False))


def _entries_yaml(entries: dict[str, Any]) -> str:
    """The lines ``entries`` take inside metadata.yaml's top mapping."""
    # An entry of a block mapping, and an item of a block list, is written the same whatever
    # its neighbours (no anchors: every mapping in the document is a new one), so pieces
    # written apart join into the text of the whole.
    text = metadata_yaml({_ROOT: entries})
    return text[text.index("\n") + 1 :]


def list_item_yaml(key: str, item: Any) -> str:
    """The text of ``item`` as an item of the list ``key`` of metadata.yaml (``files``,
    ``relative_file_paths``), for ``write_metadata``'s ``preceding``."""
    text = _entries_yaml({key: [item]})
    return text[text.index("\n") + 1 :]  # without the line of the key


def _document_yaml(info: dict[str, Any], preceding: Mapping[str, Sequence[str]]) -> str:
    """metadata.yaml's text: ``info``, its lists after the items ``preceding`` gives."""
    parts = [f"{_ROOT}:\n"]
    plain: dict[str, Any] = {}  # entries with nothing before them, written together
    for key, value in info.items():
        before = preceding.get(key)
        if not before:
            plain[key] = value
            continue
        if plain:
            parts.append(_entries_yaml(plain))
            plain = {}
        own = _entries_yaml({key: list(value) or [None]})  # the key's line, from the dumper
        head, _, own_items = own.partition("\n")
        parts += [head, "\n", *before]
        if value:
            parts.append(own_items)
    if plain:
        parts.append(_entries_yaml(plain))
    return "".join(parts)


def write_metadata(
    path: Path, metadata: BagMetadata, *, preceding: Mapping[str, Sequence[str]] | None = None
) -> None:
    """Write ``metadata`` as a version-8 metadata.yaml (``ros2 bag`` and rosbags read it).

    ``preceding`` maps a list of the document (``files``, ``relative_file_paths``) to the text
    (``list_item_yaml``) of items written before ``metadata``'s own: a split bag rewrites its
    metadata at every split, and writing each finished file's items again each time made a
    split cost more with every file before it.
    """
    text = _document_yaml(metadata_info(metadata), preceding or {})
    from pyconnect.record.log_values import atomic_write_bytes

    atomic_write_bytes(path, text.encode("utf-8"))
