"""Atheris-style byte mutations of CDR messages: flips, interesting words, cuts and splices."""

from __future__ import annotations

import random
import struct

INTERESTING_U32 = (0, 1, 2, 3, 4, 7, 8, 0x7F, 0x80, 0xFF, 0x100, 0xFFFF, 0x10000, 0x7FFFFFFF,
                   0x80000000, 0xFFFFFFFE, 0xFFFFFFFF, 0x3FFFFFFF, 0x40000000)  # fmt: skip
INTERESTING_8 = (
    struct.pack("<d", float("nan")), struct.pack("<d", float("inf")), struct.pack("<d", -1e308),
    struct.pack("<q", -1), struct.pack("<q", 2**63 - 1), struct.pack("<q", -(2**63)),
)  # fmt: skip
HEADERS = (b"\x00\x01\x00\x00", b"\x00\x00\x00\x00", b"\x00\x03\x00\x00", b"\x01\x01\x00\x00")


def _word(rng: random.Random, data: bytearray) -> int:
    """A 4-aligned position after the header (CDR counts and lengths sit there)."""
    if len(data) < 8:
        return 4
    return 4 + 4 * rng.randrange((len(data) - 4) // 4)


def _flip_bit(rng: random.Random, data: bytearray, _seeds: list[bytes]) -> None:
    if data:
        at = rng.randrange(len(data))
        data[at] ^= 1 << rng.randrange(8)


def _set_byte(rng: random.Random, data: bytearray, _seeds: list[bytes]) -> None:
    if data:
        data[rng.randrange(len(data))] = rng.choice((0, 1, 0x7F, 0x80, 0xFF, rng.randrange(256)))


def _set_count(rng: random.Random, data: bytearray, _seeds: list[bytes]) -> None:
    at = _word(rng, data)
    near = len(data) - at + rng.randrange(-8, 9)
    value = rng.choice((*INTERESTING_U32, near & 0xFFFFFFFF, rng.getrandbits(32)))
    data[at : at + 4] = struct.pack(rng.choice("<>") + "I", value)


def _set_wide(rng: random.Random, data: bytearray, _seeds: list[bytes]) -> None:
    at = _word(rng, data)
    data[at : at + 8] = rng.choice(INTERESTING_8)


def _truncate(rng: random.Random, data: bytearray, _seeds: list[bytes]) -> None:
    if data:
        del data[rng.randrange(len(data)) :]


def _extend(rng: random.Random, data: bytearray, _seeds: list[bytes]) -> None:
    data.extend(rng.randbytes(rng.choice((1, 2, 3, 4, 8, 16, 64))))


def _insert(rng: random.Random, data: bytearray, _seeds: list[bytes]) -> None:
    at = rng.randrange(len(data) + 1)
    data[at:at] = rng.randbytes(rng.choice((1, 4, 8)))


def _delete(rng: random.Random, data: bytearray, _seeds: list[bytes]) -> None:
    if len(data) > 4:
        at = rng.randrange(4, len(data))
        del data[at : at + rng.choice((1, 2, 4, 8, 16))]


def _splice(rng: random.Random, data: bytearray, seeds: list[bytes]) -> None:
    other = rng.choice(seeds)
    if len(other) > 4 and len(data) > 4:
        start = rng.randrange(4, len(other))
        chunk = other[start : start + rng.randrange(1, 64)]
        at = rng.randrange(4, len(data))
        data[at : at + len(chunk)] = chunk


def _header(rng: random.Random, data: bytearray, _seeds: list[bytes]) -> None:
    data[:4] = rng.choice(HEADERS)


MUTATORS = (_flip_bit, _set_byte, _set_count, _set_count, _set_wide, _truncate, _extend,
            _insert, _delete, _splice, _header)  # fmt: skip


def mutate(rng: random.Random, seed: bytes, seeds: list[bytes]) -> bytes:
    """1-4 stacked mutations of ``seed``; now and then a random byte string instead."""
    if rng.random() < 0.03:
        return rng.choice(HEADERS[:2]) + rng.randbytes(rng.randrange(0, 64))
    data = bytearray(seed)
    for _ in range(rng.choice((1, 1, 1, 2, 2, 3, 4))):
        rng.choice(MUTATORS)(rng, data, seeds)
    return bytes(data)
