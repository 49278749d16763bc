"""The columns of a topic's table: one typed Arrow column per field path of a type's definition.

``columns_of`` walks a type's definition rows (as the wire codecs hold them) and gives each
field its Arrow type and the way its values are built (pyconnect.record.tables says which ROS
field becomes which column and why); ``schema_of`` puts ``log_time_ns`` first and the topic and
type in the schema's metadata.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import pyarrow as pa

from pyconnect.record.image_files import IMAGE_TYPE, PATH_COLUMN

__all__ = ["TIME_COLUMN", "Column", "Definitions", "ImageColumns", "columns_of", "schema_of"]

TIME_COLUMN = "log_time_ns"
ImageColumns = Literal["binary", "files"]

_PRIMITIVES: dict[str, pa.DataType] = {
    "bool": pa.bool_(),
    "byte": pa.uint8(),
    "octet": pa.uint8(),
    "char": pa.uint8(),
    "uint8": pa.uint8(),
    "int8": pa.int8(),
    "uint16": pa.uint16(),
    "int16": pa.int16(),
    "uint32": pa.uint32(),
    "int32": pa.int32(),
    "uint64": pa.uint64(),
    "int64": pa.int64(),
    "float32": pa.float32(),
    "float64": pa.float64(),
    "float": pa.float32(),
    "double": pa.float64(),
    "wchar": pa.uint16(),
}
_BYTES = frozenset({"byte", "octet", "char", "uint8"})
Definitions = Any  # Mapping[type name, (hash, field rows)], as the wire codecs hold them


@dataclass(frozen=True)
class Column:
    """One column of a topic's table: the field path, its Arrow type and how to build it."""

    path: tuple[str, ...]
    arrow_type: pa.DataType
    build: str  # "scalar", "binary", "numbers", "fixed_numbers", "nested", "image_file"
    # Some definition the topic is read with lacks this field (merged bags of two versions of
    # the type): the rows decoded with it are null here. pandas needs to know before reading
    # (``table_pandas``): numpy integers hold no null.
    nullable: bool = False

    @property
    def name(self) -> str:
        if self.build == "image_file":  # ``path`` is the image's, the column its file's
            return ".".join((*self.path, PATH_COLUMN))
        return ".".join(self.path)


def _element_type(kind: str, element: str, definitions: Definitions) -> pa.DataType:
    if kind == "primitive":
        return _PRIMITIVES[element]
    if kind in ("string", "wstring"):
        return pa.string()
    return _struct_type(element, definitions)


def _bytes_type(container: str, size: int | None) -> pa.DataType:
    """A ``uint8``/``byte`` array or sequence: ``uint8[N]`` keeps its size, as a column or nested
    in a struct alike."""
    return pa.binary(size) if container == "array" else pa.binary()


def _struct_type(msg_type: str, definitions: Definitions) -> pa.DataType:
    fields = []
    for name, kind, element, _bound, container, size, _default in definitions[msg_type][1]:
        item = _element_type(kind, element, definitions)
        if container == "single":
            fields.append(pa.field(name, item))
        elif kind == "primitive" and element in _BYTES:
            fields.append(pa.field(name, _bytes_type(container, size)))
        elif container == "array":
            fields.append(pa.field(name, pa.list_(item, size)))
        else:
            fields.append(pa.field(name, pa.list_(item)))
    if not fields:
        # Parquet cannot store a struct without children; rosidl's C structs add this same
        # placeholder member to empty messages. It is always null.
        fields.append(pa.field("structure_needs_at_least_one_member", pa.uint8()))
    return pa.struct(fields)


def columns_of(
    msg_type: str, definitions: Definitions, *, images: ImageColumns = "binary"
) -> list[Column]:
    """The columns of ``msg_type`` (after ``log_time_ns``), in definition order.

    ``images="files"``: the ``data`` of each (not nested in a sequence) ``sensor_msgs/Image``
    is one ``data_path`` string column instead of a binary one.
    """
    columns: list[Column] = []

    def walk(type_name: str, prefix: tuple[str, ...]) -> None:
        as_file = images == "files" and type_name == IMAGE_TYPE
        for name, kind, element, _bound, container, size, _default in definitions[type_name][1]:
            path = (*prefix, name)
            if as_file and name == "data":
                columns.append(Column(prefix, pa.string(), "image_file"))
            elif container == "single":
                if kind == "message":
                    walk(element, path)
                else:
                    scalar = _element_type(kind, element, definitions)
                    columns.append(Column(path, scalar, "scalar"))
            elif kind == "primitive" and element in _BYTES:
                columns.append(Column(path, _bytes_type(container, size), "binary"))
            elif kind == "primitive" and element != "bool":
                item = _PRIMITIVES[element]
                if container == "array":
                    columns.append(Column(path, pa.list_(item, size), "fixed_numbers"))
                else:
                    columns.append(Column(path, pa.list_(item), "numbers"))
            else:
                item = _element_type(kind, element, definitions)
                list_type = pa.list_(item, size) if container == "array" else pa.list_(item)
                columns.append(Column(path, list_type, "nested"))

    walk(msg_type, ())
    return columns


def schema_of(columns: Sequence[Column], *, topic: str, msg_type: str) -> pa.Schema:
    """The table schema: ``log_time_ns`` then ``columns``; the topic and type as metadata
    (and ``images: files`` when image data are files).

    A column named ``log_time_ns`` raises ``ValueError``: the table would hold two columns of
    one name (``tables.topic_columns`` refuses such a field with a ``BagError`` naming the bag).
    """
    if any(column.name == TIME_COLUMN for column in columns):
        raise ValueError(
            f"columns: {topic}: a column named {TIME_COLUMN} (of {msg_type}) would be a second "
            "column of the log time's name"
        )
    fields = [pa.field(TIME_COLUMN, pa.int64(), nullable=False)]
    fields += [pa.field(column.name, column.arrow_type) for column in columns]
    metadata = {"topic": topic, "msg_type": msg_type}
    if any(column.build == "image_file" for column in columns):
        metadata["images"] = "files"
    return pa.schema(fields, metadata=metadata)
