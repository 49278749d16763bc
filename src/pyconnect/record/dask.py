"""``read_bags``: one topic of many bags as a Dask DataFrame, read by the workers of a cluster.

``read_bags(paths, topic="/imu/data")`` returns a lazy ``dask.dataframe.DataFrame`` with the
columns (and dtypes) of ``open_bag(path).to_pandas(topic)``: one partition per bag, or, for an
MCAP bag bigger than ``partition_bytes``, one per range of its chunks (split by log time; a
damaged file without a readable index, such as a recording cut short, stays one partition). Each
worker opens its bag itself and decodes it with the same wire codecs as a serial read, so
``read_bags(paths, topic=t).compute()`` has the rows of the serial reads, bag after bag, in the
columns of ``open_bag(paths).to_pandas(topic)``: bags that store different definitions of the
topic's type give every partition the union of their columns (``pyconnect.record.tables``). A
bag without the topic gives no partition (as it gives ``open_bag(paths)`` no rows); no bag with
it raises the ``BagError`` of ``open_bag(paths, topics=[topic])`` when the frame is planned.

The dtypes are known before any row is read: an integer or bool column that some definition
lacks (null in the rows of those bags) has a pandas nullable dtype (``UInt64``, ``boolean``) in
the meta and every partition, nulls or not (``pyconnect.record.table_pandas``); every other
column has the numpy dtype of ``to_pandas``.

The paths must be readable by every worker under the same name (a shared file system, or the
same copy on each machine); the client only reads each bag's summary and the topic's first
message, to plan the partitions and their columns.
Needs the ``scale`` extra (dask, distributed).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import dask
import dask.dataframe as dd
import pandas as pd

from pyconnect.record.bag_files import locate_bag_files
from pyconnect.record.bag_info import bag_info
from pyconnect.record.bag_reader import open_bag
from pyconnect.record.table_pandas import table_to_pandas
from pyconnect.record.tables import Column, schema_of, topic_columns, topic_table

__all__ = ["BagPart", "plan_parts", "read_bags", "read_part"]

DEFAULT_PARTITION_BYTES = 256 * 1024 * 1024


@dataclass(frozen=True)
class BagPart:
    """One partition: the messages of ``topic`` in ``path`` logged in [start_ns, end_ns)."""

    path: str
    topic: str
    start_ns: int | None = None
    end_ns: int | None = None


def read_part(
    part: BagPart, *, table_columns: tuple[Sequence[Column], str] | None = None
) -> pd.DataFrame:
    """The rows of one partition (runs on a worker), in ``table_columns`` (the columns and type
    name of every bag read together, ``tables.topic_columns``) or else its bag's own.

    Not named ``columns``: Dask gives a function's ``columns`` argument a projection of its own.
    """
    with open_bag(
        part.path, topics=[part.topic], start_ns=part.start_ns, end_ns=part.end_ns
    ) as bag:
        table = topic_table(bag, part.topic, columns=table_columns)
    return table_to_pandas(table, nullable=_nullable(table_columns))


def _nullable(table_columns: tuple[Sequence[Column], str] | None) -> set[str]:
    """The columns every partition (and the meta) gives a nullable dtype, null here or not: the
    meta is made before any row is read, so it can only go by the columns some definition
    lacks, and the partitions follow it."""
    chosen = () if table_columns is None else table_columns[0]
    return {column.name for column in chosen if column.nullable}


def _chunk_starts(path: Path) -> list[int]:
    """Log times at which the MCAP file's chunks start, sorted (empty when it has no usable
    index: then the bag is one partition)."""
    from mcap.reader import make_reader

    try:
        with open(path, "rb") as stream:
            summary = make_reader(stream).get_summary()
    except Exception:  # damaged (cut short, bad footer): the worker's open_bag
        # reads what is intact and reports the damage, as a serial read does.
        return []
    if summary is None:
        return []
    return sorted(index.message_start_time for index in summary.chunk_indexes)


def plan_parts(
    path: str | Path, topic: str, *, partition_bytes: int = DEFAULT_PARTITION_BYTES
) -> list[BagPart]:
    """The partitions of one bag: itself, or time ranges of about ``partition_bytes`` each;
    none when the bag lacks ``topic`` (of bags read together, only some may have it)."""
    _check_partition_bytes(partition_bytes)
    if topic not in {info.name for info in bag_info(path).topics}:
        return []
    located = locate_bag_files(path)
    whole = [BagPart(str(path), topic)]
    size = sum(file.stat().st_size for file in located.files)
    if size <= partition_bytes or any(file.suffix != ".mcap" for file in located.files):
        return whole
    starts = sorted({t for file in located.files for t in _chunk_starts(file)})
    wanted = min(len(starts), -(-size // partition_bytes))
    if wanted < 2:
        return whole
    step = len(starts) / wanted
    bounds = sorted({starts[round(i * step)] for i in range(1, wanted)})
    edges: list[int | None] = [None, *bounds, None]
    return [
        BagPart(str(path), topic, start_ns=edges[i], end_ns=edges[i + 1])
        for i in range(len(edges) - 1)
    ]


def _check_partition_bytes(value: object) -> None:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(
            f"partition_bytes: expected an int > 0, got {value!r} ({type(value).__name__})"
        )
    if value <= 0:
        raise ValueError(f"partition_bytes: expected an int > 0, got {value}")


def _columns(paths: Sequence[str | Path], topic: str) -> tuple[list[Column], str]:
    with open_bag(paths, topics=[topic], natural=False) as bag:
        return topic_columns(bag, topic)


def _meta(columns: tuple[Sequence[Column], str], topic: str) -> pd.DataFrame:
    chosen, msg_type = columns
    schema = schema_of(chosen, topic=topic, msg_type=msg_type)
    return table_to_pandas(schema.empty_table(), nullable=_nullable(columns))


def read_bags(
    paths: Iterable[str | Path],
    *,
    topic: str,
    partition_bytes: int = DEFAULT_PARTITION_BYTES,
) -> Any:
    """``topic`` of every bag in ``paths`` as one Dask DataFrame (see the module docstring)."""
    _check_partition_bytes(partition_bytes)
    chosen: Sequence[str | Path] = [paths] if isinstance(paths, str | Path) else list(paths)
    if not chosen:
        raise ValueError("paths: expected at least one bag")
    # One set of columns for every partition: each bag's own would leave out the fields of the
    # definitions stored in the others, and the frame would disagree with its meta. Read first:
    # when no bag has the topic, this raises the error open_bag(paths) gives.
    columns = _columns(chosen, topic)
    meta = _meta(columns, topic)
    parts = [
        part for path in chosen for part in plan_parts(path, topic, partition_bytes=partition_bytes)
    ]
    # Keep to_pandas's dtypes: without this, Dask turns string columns into its own type.
    with dask.config.set({"dataframe.convert-string": False}):
        return dd.from_map(  # type: ignore[no-untyped-call]
            read_part, parts, meta=meta, enforce_metadata=False, table_columns=columns
        )
