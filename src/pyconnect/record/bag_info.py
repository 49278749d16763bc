"""``BagInfo``: what ``ros2 bag info`` shows of one or several bags, from their storage files."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from pyconnect.record.bag_damage import BagDamage
from pyconnect.record.bag_files import BagFiles, BagPaths, is_storage_file_name, open_bag_files
from pyconnect.record.bag_metadata import METADATA_FILE, TopicMetadata
from pyconnect.record.bag_storage import StorageFile
from pyconnect.record.topic_decoder import normalise_type_name

__all__ = ["BagInfo", "TopicInfo", "bag_info", "describe", "storage_damage"]

SERVICE_EVENT_SUFFIX = "/_service_event"


@dataclass(frozen=True)
class TopicInfo:
    """A topic of a bag with one of its types: how it is serialised and how many messages of
    that type it has (a topic carried by two types is two of these, as ``ros2 bag info`` lists
    each topic and type).

    ``type_hash`` is the RIHS01 hash the bag stores for the type ("" when it stores none).
    """

    name: str
    msg_type: str
    message_count: int
    serialization_format: str = "cdr"
    has_definition: bool = False
    type_hash: str = ""
    offered_qos_profiles: str = ""
    """The publishers' QoS as rosbag2 stores it (a YAML list; "" when the bag stores none):
    from metadata.yaml, else from the storage file (an MCAP channel's metadata, a .db3 row),
    so a bare ``.mcap`` plays a latched topic latched, as its directory does."""

    @property
    def is_service_event(self) -> bool:
        """A Jazzy service event topic (``/name/_service_event``, type ``pkg/srv/Name_Event``)."""
        return self.name.endswith(SERVICE_EVENT_SUFFIX) and self.msg_type.endswith("_Event")


@dataclass(frozen=True)
class BagInfo:
    """What ``pyconnect bag info`` prints. Times are ns since the epoch (None: no messages).

    ``damage`` lists what is broken in the files as far as opening them shows (a bag cut
    short, an index pointing past the end, a chunk of an unknown compression or an impossible
    size, a ``.db3`` row that cannot be read), then where metadata.yaml disagrees with them;
    a wrong CRC or data that do not decompress inside an MCAP chunk appear when the chunk is
    read (``info`` reads no chunk, as ``ros2 bag info`` reads only the summary).
    """

    path: Path
    storage: str
    files: tuple[Path, ...]
    topics: tuple[TopicInfo, ...]
    """One per topic and type, by topic name (a topic's types in the order the bag declares
    them): a topic carried by two types has two, each with its own count."""
    start_ns: int | None
    end_ns: int | None
    damage: tuple[BagDamage, ...] = field(default=())
    metadata_damage: tuple[BagDamage, ...] = field(default=())
    """Where metadata.yaml disagrees with the storage files (a file it lists that is missing, a
    file it does not list, counts that differ from theirs); these are the last entries of
    ``damage`` too."""

    @property
    def message_count(self) -> int:
        return sum(topic.message_count for topic in self.topics)

    @property
    def duration_ns(self) -> int:
        if self.start_ns is None or self.end_ns is None:
            return 0
        return self.end_ns - self.start_ns

    @property
    def size_bytes(self) -> int:
        """The storage files' total size in bytes."""
        return sum(path.stat().st_size for path in self.files if path.exists())

    @property
    def services(self) -> tuple[TopicInfo, ...]:
        """The service event topics (rosbag2 Jazzy records services as these)."""
        return tuple(topic for topic in self.topics if topic.is_service_event)


def _storage_name(files: Iterable[StorageFile]) -> str:
    # A file compressed whole is read through a wrapper around the storage of its copy.
    kinds = {type(getattr(f, "inner", f)).__name__ for f in files}
    names = {"McapFile": "mcap", "SqliteFile": "sqlite3"}
    return "+".join(sorted(names.get(kind, kind) for kind in kinds)) or "none"


@dataclass
class _TopicTally:
    msg_type: str
    serialization_format: str
    count: int = 0
    has_definition: bool = False
    type_hash: str = ""
    offered_qos_profiles: str = ""


def storage_damage(storages: Iterable[StorageFile]) -> tuple[BagDamage, ...]:
    """What the storage files have noted as damaged so far."""
    found: list[BagDamage] = []
    for storage in storages:
        log = getattr(storage, "damage", None)
        if log is not None:
            found.extend(log.found)
    return tuple(found)


def _metadata_damage(located: BagFiles, stored: dict[str, int], damaged: bool) -> list[BagDamage]:
    """Where a bag's metadata.yaml disagrees with its storage files (``stored``: their counts).

    A storage file in the bag's directory that metadata.yaml does not list is not read (rosbag2
    reads the listed ones only): said, not skipped in silence; a file it lists that is not in the
    bag is said too (the others are read). Per-topic counts that differ from the files' are said
    unless the files are ``damaged`` or one is missing (that says why fewer were read).
    """
    metadata = located.metadata
    if metadata is None:
        return []
    where = str(located.path / METADATA_FILE)
    found = [
        BagDamage(
            where, None, f"lists {relative}, which is not in the bag; its messages are not read"
        )
        for relative in located.missing
    ]
    listed = {path.resolve() for path in located.files}
    found.extend(
        BagDamage(where, None, f"does not list {path.name}, a storage file of the bag; not read")
        for path in sorted(located.path.iterdir())
        if is_storage_file_name(path) and path.is_file() and path.resolve() not in listed
    )
    if not damaged and not located.missing:
        declared: dict[str, int] = {}  # a topic of two types is listed twice: one count each
        for topic in metadata.topics:
            declared[topic.name] = declared.get(topic.name, 0) + topic.message_count
        found.extend(
            BagDamage(
                where,
                None,
                f"{name}: declares {count} message(s), "
                f"the storage files hold {stored.get(name, 0)}",
            )
            for name, count in declared.items()
            if stored.get(name, 0) != count
        )
    return found


def _add_listed(
    tallies: dict[tuple[str, str], _TopicTally], listed: TopicMetadata
) -> dict[tuple[str, str], _TopicTally]:
    """``tallies`` with what metadata.yaml says of a topic and type (``listed``) added: it fills
    in what the files lack, and a topic and type it lists that no file holds (a recording cut
    before its channel records) is still one of the bag, with the messages the files hold, none.
    """
    # The files' own spelling of the type wins: metadata.yaml may say std_msgs/String for the
    # channel's std_msgs/msg/String, which is no second type of the topic.
    same = normalise_type_name(listed.msg_type)
    key = next(
        (k for k in tallies if k[0] == listed.name and k[1] and normalise_type_name(k[1]) == same),
        (listed.name, listed.msg_type),
    )
    untyped = (listed.name, "")
    if key not in tallies and listed.msg_type and untyped in tallies:
        # A channel with no schema: metadata.yaml names its type (the order stays the bag's).
        tallies = {(key if k == untyped else k): tally for k, tally in tallies.items()}
        tallies[key].msg_type = listed.msg_type
    tally = tallies.setdefault(
        key, _TopicTally(listed.msg_type, listed.serialization_format or "cdr")
    )
    tally.type_hash = tally.type_hash or listed.type_description_hash
    # metadata.yaml is what rosbag2 plays from; the files' own copy fills in for it
    tally.offered_qos_profiles = listed.offered_qos_profiles or tally.offered_qos_profiles
    if listed.serialization_format not in ("", "cdr"):
        tally.serialization_format = listed.serialization_format
    return tallies


def describe(bags: Iterable[tuple[BagFiles, list[StorageFile]]]) -> BagInfo:
    """Counts and times from the storage files; metadata.yaml only adds what they lack."""
    # Per topic and type: a topic carried by two types (two MCAP channels, merged bags) is
    # two topics for whoever reads the info, each with the count of its own messages.
    tallies: dict[tuple[str, str], _TopicTally] = {}
    all_storages: list[StorageFile] = []
    all_files: list[Path] = []
    first_path: Path | None = None
    disagreements: list[BagDamage] = []
    for located, storages in bags:
        first_path = first_path or located.path
        all_storages.extend(storages)
        all_files.extend(located.files)
        stored: dict[str, int] = {}  # this bag's counts, to compare with its metadata.yaml
        for storage in storages:
            counts = storage.message_counts()
            for connection in storage.connections():
                count = counts.get(connection.id, 0)
                stored[connection.topic] = stored.get(connection.topic, 0) + count
                tally = tallies.setdefault(
                    (connection.topic, connection.msg_type),
                    _TopicTally(connection.msg_type, connection.serialization_format),
                )
                tally.count += count
                tally.has_definition |= connection.definition is not None
                tally.type_hash = tally.type_hash or connection.type_hash
                tally.offered_qos_profiles = (
                    tally.offered_qos_profiles or connection.offered_qos_profiles
                )
        disagreements += _metadata_damage(located, stored, bool(storage_damage(storages)))
        for listed in located.metadata.topics if located.metadata is not None else ():
            tallies = _add_listed(tallies, listed)
    ranges = [r for r in (s.time_range() for s in all_storages) if r is not None]
    return BagInfo(
        path=first_path or Path(),
        storage=_storage_name(all_storages),
        files=tuple(all_files),
        topics=tuple(
            TopicInfo(
                name=name,
                msg_type=tally.msg_type,
                message_count=tally.count,
                serialization_format=tally.serialization_format,
                has_definition=tally.has_definition,
                type_hash=tally.type_hash,
                offered_qos_profiles=tally.offered_qos_profiles,
            )
            # by name; a topic's types in the order the bag declares them (sorted is stable)
            for (name, _msg_type), tally in sorted(tallies.items(), key=lambda item: item[0][0])
        ),
        start_ns=min(r[0] for r in ranges) if ranges else None,
        end_ns=max(r[1] for r in ranges) if ranges else None,
        damage=storage_damage(all_storages) + tuple(disagreements),
        metadata_damage=tuple(disagreements),
    )


def bag_info(path: BagPaths) -> BagInfo:
    """Topics, types, message counts, time range and damage of a bag, from its storage files."""
    bags: list[tuple[BagFiles, list[StorageFile]]] = []
    try:
        return describe(open_bag_files(path, into=bags, caller="bag_info"))
    finally:
        for _, storages in bags:
            for storage in storages:
                storage.close()
