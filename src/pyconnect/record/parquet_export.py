"""``export_parquet``: one Parquet file per bag topic, with the columns of ``tables.topic_table``.

``export_parquet("run1", "out/")`` writes ``out/odom.parquet``, ``out/robot__camera__image.parquet``
(the topic name with ``/`` as ``__``; topics whose names clean alike, ``/a/b`` and ``/a__b``, get
``a__b`` and ``a__b_2``), one per topic unless ``topics`` names some. DuckDB, polars,
pandas and Spark read them; the schema metadata holds the topic and the type.
``images="files"`` writes images as files beside them (``out/robot__camera__image/00000000.png``)
and their paths, relative to the Parquet files, in a ``data_path`` column (``image_files``).

A directory holding an earlier export is refused unless ``force``, whatever bag or topics it
was of (one directory holding the tables of two bags would read as one export): an earlier
export is any Parquet file there with a topic in its metadata (pyconnect's), one at a name this
export writes, and the image files (``00000000.png``, ``.npy``, ``.bin``) its tables list or that
lie in a folder this export writes images to (an export stopped before its table was written).
``force`` removes those files first, and the folders they leave empty, never anything else.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

import pyarrow as pa
import pyarrow.parquet as pq

from pyconnect.record.bag_damage import BagDamage
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_reader import BagReader, DecodeProblem, open_bag
from pyconnect.record.image_files import PATH_COLUMN
from pyconnect.record.log_dirs import distinct_path_components
from pyconnect.record.tables import ImageColumns, topic_columns, topic_table

__all__ = ["ParquetExport", "export_parquet"]

_IMAGE_FILE = re.compile(r"[0-9]{8}\.(png|npy|bin)")  # the names ImageFiles gives


@dataclass
class ParquetExport:
    """What ``export_parquet`` wrote: topic -> (file, rows), the messages it left out, the
    damage the bag showed (what a cut or corrupt file kept from being read), and ``notes``: the
    topics left out because they cannot be decoded (json, no schema), when none were named."""

    directory: Path
    files: dict[str, tuple[Path, int]] = field(default_factory=dict)
    errors: list[DecodeProblem] = field(default_factory=list)
    damage: list[BagDamage] = field(default_factory=list)
    damage_summary: str = ""
    notes: list[str] = field(default_factory=list)


def export_parquet(
    bag: str | Path,
    directory: str | Path,
    *,
    topics: Iterable[str] | None = None,
    compression: str = "zstd",
    images: ImageColumns = "binary",
    force: bool = False,
) -> ParquetExport:
    """Write each topic of ``bag`` (or of ``topics``) to ``directory/<topic>.parquet``.

    An earlier export in ``directory`` (of any bag, see the module docstring) raises
    ``BagError`` unless ``force`` (its files are then removed first, so that neither another
    bag's tables nor stale images survive), as the other export formats do.
    """
    target = Path(directory)
    result = ParquetExport(target)
    with open_bag(bag, topics=topics) as reader:
        # Topics that clean to one name (/a/b, /a__b) must not share a file or an image folder.
        names = distinct_path_components(sorted(reader.topics))
        image_folders = [
            names[topic]
            for topic in reader.topics
            if images == "files" and _writes_image_files(reader, topic)
        ]
        earlier = _earlier_export(target, [names[topic] for topic in reader.topics], image_folders)
        if earlier and not force:
            raise BagError(
                f"{target}: already holds an export ({earlier[0].relative_to(target)}); "
                "use force=True (--force) to overwrite it"
            )
        _remove(earlier, target)
        target.mkdir(parents=True, exist_ok=True)
        for topic in reader.topics:
            table = topic_table(
                reader,
                topic,
                errors=result.errors,
                images=images,
                image_dir=target if images == "files" else None,
                image_folder=names[topic],
            )
            path = target / f"{names[topic]}.parquet"
            pq.write_table(table, path, compression=compression)
            result.files[topic] = (path, table.num_rows)
        result.damage = list(reader.damage)
        result.notes = list(reader.notes)
        if result.damage:
            read = sum(rows for _path, rows in result.files.values()) + len(result.errors)
            result.damage_summary = reader.damage_summary(result.damage, read=read)
    return result


def _our_schema(path: Path) -> pa.Schema | None:
    """The schema of a table of pyconnect's (the topic and type in its metadata, as
    ``schema_of`` puts them); None for any other file, or one that cannot be read."""
    try:
        schema = pq.read_schema(path)
    except (OSError, ValueError, pa.ArrowException):  # not Parquet, or cut short
        return None
    metadata = schema.metadata or {}
    return schema if b"topic" in metadata and b"msg_type" in metadata else None


def _listed_images(table: Path, schema: pa.Schema, target: Path) -> list[Path]:
    """The image files a table of an ``images="files"`` export lists (its ``data_path``
    columns), those that exist under ``target``."""
    if (schema.metadata or {}).get(b"images") != b"files":
        return []
    wanted = [
        column.name
        for column in schema
        if column.name.rsplit(".", 1)[-1] == PATH_COLUMN and column.type == pa.string()
    ]
    if not wanted:
        return []
    try:
        listed = pq.read_table(table, columns=wanted)
    except (OSError, ValueError, pa.ArrowException):  # its pages are damaged: it lists none
        return []
    found: list[Path] = []
    for column in listed.columns:
        for text in column.to_pylist():
            relative = PurePosixPath(text) if isinstance(text, str) else None
            # Only paths ImageFiles writes: a table naming ../x or /etc/x is not ours to follow.
            if (
                relative is None
                or relative.is_absolute()
                or ".." in relative.parts
                or not _IMAGE_FILE.fullmatch(relative.name)
            ):
                continue
            path = target.joinpath(*relative.parts)
            if path.is_file():
                found.append(path)
    return found


def _writes_image_files(reader: BagReader, topic: str) -> bool:
    """Whether ``topic``'s table under ``images="files"`` has an image file column."""
    columns, _msg_type = topic_columns(reader, topic, images="files")
    return any(column.build == "image_file" for column in columns)


def _earlier_export(target: Path, table_names: list[str], image_folders: list[str]) -> list[Path]:
    """The files of an earlier export in ``target``: its tables first, then its images.

    ``table_names``: the names of the tables this export writes (``<name>.parquet``);
    ``image_folders``: the folders it writes image files to (``<name>/``), the only ones whose
    images it may take for an earlier export's without a table listing them: any other folder
    may hold the user's own files.
    """
    if not target.is_dir():
        return []
    ours = {f"{name}.parquet" for name in table_names}
    tables: list[Path] = []
    images: set[Path] = set()
    for path in sorted(target.glob("*.parquet")):
        if not path.is_file():
            continue
        schema = _our_schema(path)
        if schema is not None:
            tables.append(path)
            images.update(_listed_images(path, schema, target))
        elif path.name in ours:  # not pyconnect's, or cut short: this export would overwrite it
            tables.append(path)
    for name in image_folders:
        folder = target / name
        if folder.is_dir() and not folder.is_symlink():
            # Images of an export stopped before its table was written: they would lie
            # beside the new ones, in the folder of the same topic.
            images.update(
                path
                for path in folder.rglob("*")
                if _IMAGE_FILE.fullmatch(path.name) and path.is_file()
            )
    return [*tables, *sorted(images)]


def _remove(files: list[Path], target: Path) -> None:
    """Remove ``files`` and then the folders under ``target`` they leave empty."""
    folders: set[Path] = set()
    for path in files:
        path.unlink()
        folders.update(parent for parent in path.parents if target in parent.parents)
    for folder in sorted(folders, key=lambda p: len(p.parts), reverse=True):
        with contextlib.suppress(OSError):  # not empty: it holds files of the user's own
            folder.rmdir()
