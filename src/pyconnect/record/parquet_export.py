"""``export_parquet``: one Parquet file per bag topic, with the columns of ``tables.topic_table``.

``export_parquet("run1", "out/")`` writes ``out/odom.parquet``, ``out/robot__camera__image.parquet``
(the topic name with ``/`` as ``__``; topics whose names clean alike, ``/a/b`` and ``/a__b``, get
``a__b`` and ``a__b_2``), one per topic unless ``topics`` names some. DuckDB, polars,
pandas and Spark read them; the schema metadata holds the topic and the type.
``images="files"`` writes images as files beside them (``out/robot__camera__image/00000000.png``)
and their paths, relative to the Parquet files, in a ``data_path`` column (``image_files``).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow.parquet as pq

from pyconnect.record.bag_damage import BagDamage
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_reader import DecodeProblem, open_bag
from pyconnect.record.log_dirs import distinct_path_components
from pyconnect.record.tables import ImageColumns, topic_table

__all__ = ["ParquetExport", "export_parquet"]


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

    A Parquet file of an earlier export raises ``BagError`` unless ``force`` (then it is
    overwritten), as the other export formats do.
    """
    target = Path(directory)
    result = ParquetExport(target)
    with open_bag(bag, topics=topics) as reader:
        # Topics that clean to one name (/a/b, /a__b) must not share a file or an image folder.
        names = distinct_path_components(sorted(reader.topics))
        earlier = [
            path for topic in reader.topics if (path := target / f"{names[topic]}.parquet").exists()
        ]
        if earlier and not force:
            raise BagError(
                f"{target}: already holds an export ({earlier[0].name}); "
                "use force=True (--force) to overwrite it"
            )
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
