"""Bag topics as tables: one row per message, one typed column per field (pyarrow, pandas, polars).

``topic_table(bag, "/odom")`` reads one topic as lossless dicts and flattens each message into
columns named by their field path, typed as the ROS fields are (needs the ``tables`` extra):

- ``log_time_ns`` (int64, the time the message was logged) comes first;
- nested messages are flattened: ``pose.pose.position.x``; a header stays two time columns,
  ``header.stamp.sec`` (int32) and ``header.stamp.nanosec`` (uint32), and ``header.frame_id``;
- scalars keep their width and sign (``int8`` stays ``int8``, ``char`` is ``uint8``);
- an array or sequence field stays one column under its name: a fixed-size array of numbers is
  a fixed-size list column (a tensor per row, ``pose.covariance`` is ``fixed_size_list<double,
  36>``), a sequence of numbers a list column, ``uint8``/``byte`` sequences (image and cloud
  data) a binary column, a fixed ``uint8[N]`` a ``fixed_size_binary(N)``;
- an image is thus its binary ``data`` beside the ``height``, ``width``, ``step``,
  ``encoding`` and ``is_bigendian`` columns that give its shape and pixel type; with
  ``images="files"`` (and ``image_dir``) each image is written to a lossless PNG (or ``.npy``)
  file instead and ``data`` becomes ``data_path``, the file's path relative to ``image_dir``
  (``pyconnect.record.image_files`` says which file and why);
- sequences of messages stay one column of lists of structs (``transforms``).

Columns come from the definition the values are decoded with: the one stored in the bag, else
(none stored, or it does not fit the bytes) the installed type; a value missing from a message
(a Foxy message without a later field) is null. Merged bags (``open_bag([foxy_run, jazzy_run])``)
that store different definitions of the topic's type give the union of their columns, null where
a message's definition lacks the field; a field whose type differs between two of them raises
``BagError``, as does a topic whose values follow two definitions in one bag (the stored
definition fits its first messages, not later ones), and so do merged bags in which the topic
has two different types (``geometry_msgs/msg/Twist`` in one, ``TwistStamped`` in another).
A top-level field named ``log_time_ns`` raises ``BagError`` too: its column would share the log
time's name. ``to_pandas`` (``pyconnect.record.table_pandas``) gives an integer or bool column
with nulls a pandas nullable dtype (``UInt64``, ``boolean``), so its values stay exact.
Messages that cannot be decoded are left out and reported in the reader's ``errors``, as
``open_bag`` does.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from pyconnect.record.bag_errors import BagError
from pyconnect.record.image_files import ImageFiles
from pyconnect.record.table_columns import (
    TIME_COLUMN,
    Column,
    Definitions,
    ImageColumns,
    columns_of,
    schema_of,
)

# The bag reader calls this module (its to_arrow/to_pandas/to_polars); this module takes the
# reader it is given and never imports the reader's module, so the two stay free of a cycle.
BagReader = Any
DecodeProblem = Any

__all__ = [
    "TIME_COLUMN",
    "Column",
    "ImageColumns",
    "columns_of",
    "rows_to_table",
    "schema_of",
    "topic_columns",
    "topic_table",
    "topic_types",
]

# -- values -> Arrow arrays ----------------------------------------------------------------------
_MISSING = object()


def _get(message: Any, path: tuple[str, ...]) -> Any:
    value = message
    for key in path:
        if not isinstance(value, dict):
            return None
        value = value.get(key, _MISSING)
        if value is _MISSING:
            return None
    return value


def _plain(value: Any) -> Any:
    """Nested values as pyarrow's converter takes them: no ndarrays (uint8 ones as bytes)."""
    if isinstance(value, np.ndarray):
        return value.tobytes() if value.dtype == np.uint8 else value.tolist()
    if isinstance(value, dict):
        return {key: _plain(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(item) for item in value]
    return value


def _numbers(values: list[Any], column: Column) -> pa.Array:
    item_type = column.arrow_type.value_type
    dtype = item_type.to_pandas_dtype()
    present = [v for v in values if v is not None]
    if len(present) != len(values):  # rare: a field missing from some messages
        lists = [None if v is None else np.asarray(v).tolist() for v in values]
        return pa.array(lists, type=column.arrow_type)
    flat = (
        np.concatenate([np.asarray(v, dtype=dtype).ravel() for v in values])
        if values
        else np.empty(0, dtype)
    )
    flat_array = pa.array(flat, type=item_type)
    if column.build == "fixed_numbers":
        return pa.FixedSizeListArray.from_arrays(flat_array, column.arrow_type.list_size)
    offsets = np.zeros(len(values) + 1, dtype=np.int32)
    np.cumsum([len(v) for v in values], out=offsets[1:])
    return pa.ListArray.from_arrays(pa.array(offsets), flat_array)


def _binary(values: list[Any], column: Column) -> pa.Array:
    data = [None if v is None else bytes(v) for v in values]
    return pa.array(data, type=column.arrow_type)


def _array(values: list[Any], column: Column) -> pa.Array:
    if column.build in ("scalar", "image_file"):
        return pa.array(values, type=column.arrow_type)
    if column.build == "binary":
        return _binary(values, column)
    if column.build in ("numbers", "fixed_numbers"):
        return _numbers(values, column)
    return pa.array([_plain(v) for v in values], type=column.arrow_type)


def rows_to_table(
    rows: Iterable[tuple[int, dict[str, Any]]],
    columns: Sequence[Column],
    *,
    topic: str,
    msg_type: str,
    image_files: ImageFiles | None = None,
) -> pa.Table:
    """Flatten ``(log_time_ns, lossless dict)`` rows into a table with ``columns``.

    ``image_files`` writes the images of ``image_file`` columns (as each row is read, so the
    table never holds their pixels) and gives the paths they hold.
    """
    # Before any row is read (or image written): a bad set of columns fails at once.
    schema = schema_of(columns, topic=topic, msg_type=msg_type)
    times: list[int] = []
    values: list[list[Any]] = [[] for _ in columns]
    paths = [column.path for column in columns]
    as_files = [i for i, column in enumerate(columns) if column.build == "image_file"]
    if as_files and image_files is None:
        raise ValueError("rows_to_table: image_file columns need image_files")
    for row, (log_time_ns, message) in enumerate(rows):
        times.append(log_time_ns)
        for store, path in zip(values, paths, strict=True):
            store.append(_get(message, path))
        for i in as_files:
            assert image_files is not None
            values[i][-1] = image_files.write(values[i][-1], row, paths[i])
    arrays = [pa.array(np.asarray(times, dtype=np.int64), type=pa.int64())]
    arrays += [_array(store, column) for store, column in zip(values, columns, strict=True)]
    return pa.Table.from_arrays(arrays, schema=schema)


# -- bags ----------------------------------------------------------------------------------------
def _bag_paths(reader: BagReader) -> list[Path]:
    """Every bag an open reader merges (``open_bag([run1, run2])``), in its order."""
    paths: list[Path] = list(reader.bag_paths)
    return paths


def topic_types(reader: BagReader, topic: str) -> tuple[Definitions, str]:
    """The type definitions and type name ``topic`` is decoded with: the codec ``reader`` decodes
    it with (the bag's definition, or the installed type when that does not fit the bytes)."""
    codec = reader.topic_codec(topic)
    if codec is None:
        from pyconnect.codecs import wire

        # No codec could be built: this raises the error that says why.
        codec = wire.wire_codec(reader.topics[topic].msg_type)
    # The field rows are the codec's own description of its type (name, kind, element, bound,
    # container, size, default): the same rows its decoder was generated from.
    return codec.definitions, codec.msg_type


@dataclass(frozen=True)
class _BagColumns:
    """The columns one bag of a merged reader gives a topic, from the codec it decodes with."""

    path: Path
    msg_type: str
    columns: list[Column]


def _each_bag_columns(reader: BagReader, topic: str, images: ImageColumns) -> list[_BagColumns]:
    """The columns of each codec ``topic`` is decoded with: one a bag, or more when a bag holds
    the topic as two types or definitions (two channels of one MCAP file)."""
    # A bag with no codec for the topic: its messages are undecodable, reported when read.
    return [
        _BagColumns(
            path, codec.msg_type, columns_of(codec.msg_type, codec.definitions, images=images)
        )
        for path, codec in reader.topic_codecs(topic)
    ]


def _union(topic: str, bags: Sequence[_BagColumns]) -> list[Column]:
    """Every column of ``bags``, each after the one it follows in its own definition (a bag's
    leading new columns after those merged before it). Bags that decode the topic as two
    different types raise ``BagError``: their fields are not versions of one another."""
    first = bags[0]
    for bag in bags[1:]:
        if bag.msg_type == first.msg_type:
            continue
        if bag.path == first.path:
            raise BagError(
                f"{bag.path}: {topic}: two types in this bag, {first.msg_type} and "
                f"{bag.msg_type}; one table cannot hold both types (read them with open_bag)"
            )
        raise BagError(
            f"{bag.path}: {topic}: type {bag.msg_type} in this bag, {first.msg_type} in "
            f"{first.path}; one table cannot hold both types (read them with open_bag, or "
            "each bag on its own)"
        )
    merged: list[Column] = []
    first_seen: dict[str, tuple[Column, _BagColumns]] = {}
    for bag in bags:
        # Where this bag's next new column goes: after its previous column, or after every
        # column merged so far (the first bag's order stays the table's start).
        at = len(merged)
        for column in bag.columns:
            seen = first_seen.get(column.name)
            if seen is None:
                merged.insert(at, column)
                first_seen[column.name] = (column, bag)
                at += 1
                continue
            known, known_bag = seen
            if (known.arrow_type, known.build) != (column.arrow_type, column.build):
                if known_bag.path == bag.path:
                    raise BagError(
                        f"{bag.path}: {topic}: field {column.name} is {known.arrow_type} in one "
                        f"definition of {bag.msg_type} this bag stores, {column.arrow_type} in "
                        "another; one table cannot hold both (read them with open_bag)"
                    )
                raise BagError(
                    f"{bag.path}: {topic}: field {column.name} is {column.arrow_type} in the "
                    f"definition of {bag.msg_type} this bag is read with, {known.arrow_type} in "
                    f"that of {known_bag.path}; one table cannot hold both (read them with "
                    "open_bag)"
                )
            at = merged.index(known) + 1
    return merged


def topic_columns(
    reader: BagReader, topic: str, *, images: ImageColumns = "binary"
) -> tuple[list[Column], str]:
    """The columns of ``topic``'s table (after ``log_time_ns``) and the type name it has.

    The columns are the union over the definitions the topic is decoded with: one per bag
    read together, or more when a bag stores the topic with two (a field some lack is null in
    their rows, and its ``Column.nullable`` says so). A field whose type differs between two of
    them raises ``BagError``, as do a topic of two different types, in merged bags or in one,
    and a top-level field named ``log_time_ns`` (the log time's column).
    """
    bags = _each_bag_columns(reader, topic, images)
    if not bags:
        # No bag with a codec: this raises the error that says why.
        definitions, msg_type = topic_types(reader, topic)
        chosen = columns_of(msg_type, definitions, images=images)
        bags = [_BagColumns(Path(reader.path), msg_type, chosen)]
    for bag in bags:
        if any(column.name == TIME_COLUMN for column in bag.columns):
            # Renaming either column would break a promise: log_time_ns is the log time, every
            # other column is named by its field path. Two columns of one name break polars,
            # pandas lookups and the Parquet files' readers.
            raise BagError(
                f"{bag.path}: {topic}: field {TIME_COLUMN} of {bag.msg_type} has the name of the "
                "table's log time column; one table cannot hold both (read the topic with "
                "open_bag)"
            )
    holding = Counter(column.name for bag in bags for column in bag.columns)
    merged = [
        replace(column, nullable=True) if holding[column.name] < len(bags) else column
        for column in _union(topic, bags)
    ]
    return merged, bags[0].msg_type


def topic_table(
    bag: BagReader,
    topic: str,
    *,
    errors: list[DecodeProblem] | None = None,
    images: ImageColumns = "binary",
    image_dir: str | Path | None = None,
    image_folder: str | None = None,
    columns: tuple[Sequence[Column], str] | None = None,
) -> pa.Table:
    """One topic of an open reader (``open_bag(...)``, whose time range applies) as a table.

    Messages that cannot be decoded are appended to ``errors`` (when given) and left out.
    ``images="files"`` writes each image to a file under ``image_dir`` (see the module
    docstring), in its folder ``image_folder`` (default: the topic as a name). ``columns``:
    the columns and type name to use (``topic_columns`` of a reader of more bags, with the same
    ``images``) instead of those of ``bag``'s own definitions.
    """
    if images not in ("binary", "files"):
        raise ValueError(f"images: expected 'binary' or 'files', got {images!r}")
    if images == "files" and image_dir is None:
        raise ValueError("images='files' needs image_dir, the directory to write them to")
    if images == "binary" and image_dir is not None:
        raise ValueError("image_dir is only for images='files'")
    # A reader of the same class over the same bags, reading lossless dicts of one topic.
    with type(bag)(
        _bag_paths(bag),
        topics=[topic],
        types=bag.types,
        natural=False,
        start_ns=bag.start_ns,
        end_ns=bag.end_ns,
        on_error=bag.on_error,
    ) as reader:
        chosen, msg_type = columns or topic_columns(reader, topic, images=images)
        files = None if image_dir is None else ImageFiles(image_dir, topic, folder=image_folder)
        table = rows_to_table(
            _rows(reader), chosen, topic=topic, msg_type=msg_type, image_files=files
        )
        if errors is not None:
            errors.extend(reader.errors)
        # Damage this reader met (a page of the topic's rows) is the bag's: never dropped.
        bag.note_damage([d for d in reader.damage if d not in reader.info.metadata_damage])
        if topic in reader.switched:
            # Earlier rows hold the fields of the stored definition, later ones those of the
            # installed type: one set of columns would drop some of them without a word.
            raise BagError(
                f"{reader.path}: {topic}: the first {reader.switched[topic]} message(s) decode "
                f"with the definition of {msg_type} stored in the bag, later ones only with the "
                "installed type; one table cannot hold both (read them with open_bag)"
            )
    return table


def _rows(reader: BagReader) -> Iterator[tuple[int, dict[str, Any]]]:
    for message in reader:
        yield message.log_time_ns, message.value
