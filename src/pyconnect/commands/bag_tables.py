"""``pyconnect bag export BAG --format parquet --to DIR``: one Parquet file per topic.

All topics unless ``--topic`` names some; the columns are those of ``open_bag(...).to_arrow``
(``pyconnect.record.tables``); ``--images files`` writes each image to a lossless PNG file (or
``.npy``) beside the Parquet files, with its relative path in a ``data_path`` column in place of
the binary ``data``. Needs the ``tables`` extra. Exit status 1 when some messages could
not be decoded (they are left out and summarised on stderr) or the bag is damaged (unless
``--ignore-damage``), after writing all that could be read.
"""

from __future__ import annotations

import argparse
from typing import TextIO

from pyconnect.commands.bag_damage import damage_status
from pyconnect.commands.common import UsageError

__all__ = ["export_parquet_command"]


def export_parquet_command(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    """Run ``bag export --format parquet``."""
    try:
        from pyconnect.record.parquet_export import export_parquet
    except ImportError as error:
        # pyarrow is in the `tables` extra only: an install without it gets the command to run.
        if (error.name or "").split(".")[0] != "pyarrow":
            raise
        raise UsageError(
            "--format parquet needs pyarrow, which cannot be imported: "
            "pip install 'pyconnect-ros[tables]'"
        ) from error

    result = export_parquet(
        args.path, args.to, topics=args.topic, images=args.images, force=args.force
    )
    for topic, (path, rows) in result.files.items():
        print(f"{topic}: {rows} row(s) to {path}", file=out)
    for note in result.notes:  # topics no --topic named that cannot be decoded: not an error
        print(f"pyconnect: {note}", file=err)
    status = 0
    if result.errors:
        print(
            f"pyconnect: {len(result.errors)} message(s) not decoded; first: {result.errors[0]}",
            file=err,
        )
        status = 1
    return max(status, damage_status(result.damage, result.damage_summary, args, err))
