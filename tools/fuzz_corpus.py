"""Seed messages for the fuzzer: random valid values of every generated type, natural values,
compressed images, and every message of the shared bags with the definition stored beside it."""

from __future__ import annotations

import importlib
import pkgutil
import random
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from pyconnect.codecs import wire

_RANGES = {
    "byte": (0, 255),
    "char": (0, 255),
    "uint8": (0, 255),
    "int8": (-128, 127),
    "int16": (-(2**15), 2**15 - 1),
    "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1),
    "uint32": (0, 2**32 - 1),
    "int64": (-(2**63), 2**63 - 1),
    "uint64": (0, 2**64 - 1),
}
_TEXT = "abcxyz_/ é€漢🙂"
BAGS = Path(__file__).resolve().parent.parent.parent / "shared" / "data" / "bags"

Definitions = Mapping[str, tuple[str, tuple[Any, ...]]]


def generated_types() -> dict[str, Definitions]:
    """Every exported generated type, with the DEFINITIONS table of its package's module."""
    import pyconnect_generated

    types: dict[str, Definitions] = {}
    for info in pkgutil.iter_modules(pyconnect_generated.__path__):
        module = importlib.import_module(f"pyconnect_generated.{info.name}.wire_codecs")
        for name in sorted(module.EXPORTED):
            types[name] = module.DEFINITIONS
    return types


def _scalar(rng: random.Random, kind: str, element: str, bound: int | None) -> Any:
    if kind in ("string", "wstring"):
        return "".join(rng.choice(_TEXT) for _ in range(rng.randrange((bound or 12) + 1)))
    if element == "bool":
        return rng.random() < 0.5
    if element in ("float32", "float64"):
        return rng.choice((0.0, -1.5, 1e30, float("nan"), float("inf"), rng.uniform(-1e3, 1e3)))
    low, high = _RANGES[element]
    return rng.choice((low, high, 0, rng.randint(low, high)))


def random_dict(rng: random.Random, full_name: str, definitions: Definitions) -> dict[str, Any]:
    """A random valid lossless dict (sequences of 0-3 items, bounds respected)."""
    value: dict[str, Any] = {}
    for name, kind, element, bound, container, size, _default in definitions[full_name][1]:
        row = (kind, element, bound)
        if container == "single":
            value[name] = _element(rng, row, definitions)
            continue
        count = size if container == "array" else rng.randrange(min(size or 3, 3) + 1)
        if kind == "primitive" and element in ("byte", "uint8", "char"):
            value[name] = rng.randbytes(count)
        else:
            value[name] = [_element(rng, row, definitions) for _ in range(count)]
    return value


def _element(rng: random.Random, row: tuple[str, str, int | None], definitions: Definitions) -> Any:
    kind, element, bound = row
    if kind == "message":
        return random_dict(rng, element, definitions)
    return _scalar(rng, kind, element, bound)


def generated_seeds(rng: random.Random, per_type: int) -> dict[str, list[bytes]]:
    """Defaults plus ``per_type`` random messages of every generated type, as CDR."""
    seeds: dict[str, list[bytes]] = {}
    for full_name, definitions in generated_types().items():
        codec = wire.wire_codec(full_name)
        found = [codec.from_dict({}), codec.from_dict({}, big_endian=True)]
        for index in range(per_type):
            found.append(
                codec.from_dict(random_dict(rng, full_name, definitions), big_endian=index % 4 == 3)
            )
        seeds[full_name] = found
    return seeds


# -- natural paths ----------------------------------------------------------------------------
def image_seeds(rng: random.Random) -> list[bytes]:
    seeds = []
    for encoding, dtype, channels in (
        ("mono8", np.uint8, 1),
        ("rgb8", np.uint8, 3),
        ("bgra8", np.uint8, 4),
        ("mono16", np.uint16, 1),
        ("32FC1", np.float32, 1),
        ("16SC3", np.int16, 3),
        ("bayer_rggb8", np.uint8, 1),
        ("64FC2", np.float64, 2),
    ):
        height, width = rng.randrange(1, 6), rng.randrange(1, 6)
        itemsize = np.dtype(dtype).itemsize
        pad = rng.choice((0, 0, 4))
        step = width * channels * itemsize + pad
        value = {
            "header": {"frame_id": "cam"},
            "height": height,
            "width": width,
            "encoding": encoding,
            "is_bigendian": int(rng.random() < 0.2),
            "step": step,
            "data": rng.randbytes(step * height),
        }
        seeds.append(wire.from_dict(value, "sensor_msgs/msg/Image"))
    return seeds


def point_cloud_seeds(rng: random.Random) -> list[bytes]:
    seeds = []
    layouts = (
        [("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1)],
        [("z", 8, 7, 1), ("x", 0, 7, 1), ("y", 4, 7, 1), ("intensity", 16, 7, 1)],  # unsorted
        [("x", 0, 8, 1), ("rgb", 8, 7, 1), ("ring", 12, 4, 1), ("t", 16, 6, 2)],
    )
    for fields in layouts:
        point_step = rng.choice((24, 32, 48))
        height, width = rng.choice(((1, 3), (2, 2), (1, 0), (3, 1)))
        row_step = point_step * width + rng.choice((0, 8))
        value = {
            "header": {"frame_id": "lidar"},
            "height": height,
            "width": width,
            "fields": [
                {"name": n, "offset": o, "datatype": d, "count": c} for n, o, d, c in fields
            ],
            "is_bigendian": rng.random() < 0.2,
            "point_step": point_step,
            "row_step": row_step,
            "data": rng.randbytes(row_step * height),
            "is_dense": False,
        }
        seeds.append(wire.from_dict(value, "sensor_msgs/msg/PointCloud2"))
    return seeds


def joint_state_seeds(rng: random.Random) -> list[bytes]:
    seeds = []
    for count in (0, 1, 3, 6):
        names = [f"joint_{index}" for index in range(count)]
        value = {
            "header": {"frame_id": "base"},
            "name": names,
            "position": [rng.uniform(-3, 3) for _ in names],
            "velocity": [rng.uniform(-1, 1) for _ in names] if count % 2 else [],
            "effort": [],
        }
        seeds.append(wire.from_dict(value, "sensor_msgs/msg/JointState"))
    return seeds


def compressed_image_seeds(rng: random.Random) -> list[bytes]:
    import cv2

    from pyconnect.codecs.compressed_image import compressed_fields

    seeds = []
    pixels = rng.randbytes(16 * 12 * 3)
    colour = np.frombuffer(pixels, np.uint8).reshape(12, 16, 3)
    for form in ("jpeg", "png"):
        fields = compressed_fields(colour, format=form)
        seeds.append(wire.from_dict(fields, "sensor_msgs/msg/CompressedImage"))
    depth = np.arange(12 * 16, dtype=np.uint16).reshape(12, 16)
    ok, png = cv2.imencode(".png", depth)
    assert ok
    header = np.array([0], "<i4").tobytes() + np.array([0.0, 0.0], "<f4").tobytes()
    seeds.append(
        wire.from_dict(
            {"format": "16UC1; compressedDepth png", "data": header + png.tobytes()},
            "sensor_msgs/msg/CompressedImage",
        )
    )
    seeds.append(
        wire.from_dict(
            {
                "format": "32FC1; compressedDepth png",
                "data": np.array([0], "<i4").tobytes()
                + np.array([100.0, 0.5], "<f4").tobytes()
                + png.tobytes(),
            },
            "sensor_msgs/msg/CompressedImage",
        )
    )
    return seeds


# -- bags -----------------------------------------------------------------------------------
def bag_messages(limit_per_topic: int = 20) -> Iterator[tuple[str, str, str, bytes]]:
    """(type, definition text, encoding, CDR): up to ``limit_per_topic`` per MCAP topic."""
    from mcap.reader import make_reader

    for path in sorted(BAGS.rglob("*.mcap")):
        counts: dict[int, int] = {}
        try:
            with path.open("rb") as file:
                reader = make_reader(file)
                for schema, channel, message in reader.iter_messages():
                    if schema is None or channel.message_encoding != "cdr":
                        continue
                    seen = counts.get(channel.id, 0)
                    if seen >= limit_per_topic:
                        continue
                    counts[channel.id] = seen + 1
                    yield schema.name, schema.data.decode(), schema.encoding, bytes(message.data)
        except Exception:  # a damaged sample bag gives fewer seeds, not a crash
            continue
