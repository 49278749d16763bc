"""rmw_zenoh's (Jazzy) names on the wire: data keys, liveliness tokens, GIDs, attachments.

Everything here follows ros2/rmw_zenoh, jazzy branch (release 0.2.x), read from its source:

- ``liveliness_utils.cpp`` (``TopicInfo``): a topic's or service's data key expression is
  ``<domain_id>/<name without leading and trailing '/'>/<type name>/<RIHS01 hash>``.
- ``type_support_common.cpp`` (``_create_type_name``): the type name is
  ``<pkg>::<msg|srv>::dds_::<Name>_``; a service uses its response type's name with the
  ``Response_`` suffix cut (``rmw_service_data.cpp``), i.e. ``std_srvs::srv::dds_::SetBool_``,
  and the RIHS01 hash of the service type.
- ``liveliness_utils.cpp`` (``Entity``): a liveliness token is
  ``@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<NN|MP|MS|SS|SC>/<enclave>/<namespace>/
  <node name>[/<topic>/<type name>/<type hash>/<qos>]`` where each name has every '/' replaced by
  '%' (so the empty enclave and namespace '/' become ``%``). A node's token uses its own id as
  node id and entity id; ids count up per session (``rmw_context_impl_s.cpp``).
- ``liveliness_utils.cpp`` (``qos_to_keyexpr``): the QoS part lists reliability, durability,
  history,depth, deadline, lifespan, liveliness as ``R:D:H,depth:s,ns:s,ns:L,s,ns``, leaving
  empty every value equal to rmw_zenoh's default (``qos.cpp``: reliable, volatile, keep-last 42,
  infinite durations, automatic liveliness).
- The entity GID is the XXH3-128 hash of the token's key expression, low 64 bits first, each
  little-endian (``Entity::Entity`` with ``simplified_xxhash3``).
- ``attachment_helpers.cpp``: every sample, query and reply carries an attachment made with
  zenoh's ``ext::Serializer``: int64 sequence number, int64 source timestamp (ns since the
  epoch), then the GID as a ``std::array<uint8_t, 16>``, which zenoh-cpp's serializer writes
  as a sequence (``ext/serialization.hxx``): its length as a LEB128 varint (one byte, 16) and
  the 16 bytes; 33 bytes in all, and a reader refuses another length ("Incorrect sequence
  size"). Integers are little-endian. Sequence numbers start at 1 per publisher and client.

A token's chunks go into key expressions (its own; a data key built from its topic, type and
hash), so ``parse_token`` takes only what rmw_zenoh writes: a decimal domain and ids, a hex
zid, a hash of ``rosidl_stringify_type_hash`` (``RIHS01_`` and 64 lowercase hex digits), and no
chunk that is empty or holds a character zenoh reserves (``*`` and ``$`` make wildcards,
``?`` and ``#`` are forbidden), which no ROS name, type name or QoS chunk contains.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass

import xxhash

from pyconnect.typesys.names import parse_type_name

ADMIN_SPACE = "@ros2_lv"
NODE, PUBLISHER, SUBSCRIPTION, SERVICE, CLIENT = "NN", "MP", "MS", "SS", "SC"
ENTITY_KINDS = (NODE, PUBLISHER, SUBSCRIPTION, SERVICE, CLIENT)
GID_SIZE = 16
ATTACHMENT = struct.Struct("<qqB16s")
"""(sequence number, source timestamp ns, GID length, GID): the length is always ``GID_SIZE``."""
ATTACHMENT_SIZE = ATTACHMENT.size
TYPE_HASH = re.compile(r"RIHS01_[0-9a-f]{64}")
"""A type hash as rmw_zenoh writes it in keys and tokens."""
_DECIMAL = re.compile(r"[0-9]+")
_HEX = re.compile(r"[0-9a-f]+")
_KEY_SPECIALS = re.compile(r"[*$?#]")

# rmw_zenoh's defaults (qos.cpp): a value equal to one of these is left empty in the token.
_DEFAULT_DEPTH = 42
_RELIABILITY = {"reliable": 1, "best_effort": 2}
_DURABILITY = {"transient_local": 1, "volatile": 2}
_HISTORY_KEEP_LAST = 1


def mangle(name: str) -> str:
    """A name as a single key-expression chunk: every '/' becomes '%' (rmw_zenoh's rule)."""
    return name.replace("/", "%")


def demangle(chunk: str) -> str:
    return chunk.replace("%", "/")


def dds_type_name(type_name: str) -> str:
    """``sensor_msgs/msg/Image`` -> ``sensor_msgs::msg::dds_::Image_`` (services: no suffix)."""
    parsed = parse_type_name(type_name)
    return f"{parsed.package}::{parsed.namespace or 'msg'}::dds_::{parsed.name}_"


def ros_type_name(dds_name: str) -> str:
    """The inverse of ``dds_type_name``; other text comes back unchanged."""
    head, sep, tail = dds_name.partition("::dds_::")
    if not sep or not tail.endswith("_"):
        return dds_name
    return f"{head.replace('::', '/')}/{tail[:-1]}"


def data_key(domain_id: int, name: str, type_name: str, type_hash: str) -> str:
    """The key expression samples (or queries) of ``name`` are put on."""
    return f"{domain_id}/{name.strip('/')}/{dds_type_name(type_name)}/{type_hash}"


def qos_chunk(
    *, reliability: str = "reliable", durability: str = "volatile", depth: int = 10
) -> str:
    """The QoS chunk of a token (keep-last history; infinite deadline, lifespan, lease)."""
    rel = "" if reliability == "reliable" else str(_RELIABILITY[reliability])
    dur = "" if durability == "volatile" else str(_DURABILITY[durability])
    dep = "" if depth == _DEFAULT_DEPTH else str(depth)
    return f"{rel}:{dur}:,{dep}:,:,:,,"


@dataclass(frozen=True)
class NodeIdentity:
    """What every token of one node repeats."""

    domain_id: int
    zid: str
    node_id: int
    name: str
    namespace: str = "/"
    enclave: str = "/"

    def prefix(self, entity_id: int, kind: str) -> str:
        return (
            f"{ADMIN_SPACE}/{self.domain_id}/{self.zid}/{self.node_id}/{entity_id}/{kind}/"
            f"{mangle(self.enclave)}/{mangle(self.namespace)}/{mangle(self.name)}"
        )


def node_token(node: NodeIdentity) -> str:
    return node.prefix(node.node_id, NODE)


def entity_token(
    node: NodeIdentity,
    *,
    entity_id: int,
    kind: str,
    name: str,
    type_name: str,
    type_hash: str,
    qos: str,
) -> str:
    """The token of a publisher, subscription, service or client named ``name`` (absolute)."""
    return (
        f"{node.prefix(entity_id, kind)}/{mangle(name)}/{mangle(dds_type_name(type_name))}/"
        f"{type_hash}/{qos}"
    )


def gid_of(token: str) -> bytes:
    """The 16-byte GID rmw_zenoh derives from an entity's token."""
    value = xxhash.xxh3_128_intdigest(token.encode())
    return struct.pack("<QQ", value & 0xFFFF_FFFF_FFFF_FFFF, value >> 64)


def pack_attachment(sequence_number: int, source_timestamp_ns: int, gid: bytes) -> bytes:
    return ATTACHMENT.pack(sequence_number, source_timestamp_ns, GID_SIZE, gid)


def unpack_attachment(data: bytes) -> tuple[int, int, bytes]:
    """``(sequence number, source timestamp ns, gid)``; raises ``struct.error`` when malformed."""
    sequence_number, stamp, size, gid = ATTACHMENT.unpack(data)
    if size != GID_SIZE:
        raise struct.error(f"a GID of {size} bytes, expected {GID_SIZE}")
    return sequence_number, stamp, gid


@dataclass(frozen=True)
class Token:
    """A parsed liveliness token (what the graph keeps)."""

    key: str
    zid: str
    node_id: str
    entity_id: str
    kind: str
    enclave: str
    namespace: str
    node_name: str
    name: str = ""
    type_name: str = ""
    type_hash: str = ""


def parse_token(key: str) -> Token | None:
    """A token's fields, or None for keys that are not rmw_zenoh entity tokens (among them
    any with a wildcard or an empty chunk: a peer must never listen on such a key)."""
    parts = key.split("/")
    if len(parts) < 9 or parts[0] != ADMIN_SPACE or parts[5] not in ENTITY_KINDS:
        return None
    if not all(part and _KEY_SPECIALS.search(part) is None for part in parts):
        return None
    if not (
        _DECIMAL.fullmatch(parts[1])
        and _HEX.fullmatch(parts[2])
        and _DECIMAL.fullmatch(parts[3])
        and _DECIMAL.fullmatch(parts[4])
    ):
        return None
    fields = {
        "key": key,
        "zid": parts[2],
        "node_id": parts[3],
        "entity_id": parts[4],
        "kind": parts[5],
        "enclave": demangle(parts[6]),
        "namespace": demangle(parts[7]),
        "node_name": demangle(parts[8]),
    }
    if parts[5] != NODE:
        if len(parts) < 13 or not TYPE_HASH.fullmatch(parts[11]):
            return None
        fields.update(
            name=demangle(parts[9]),
            type_name=ros_type_name(demangle(parts[10])),
            type_hash=parts[11],
        )
    return Token(**fields)
