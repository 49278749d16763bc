"""Export topics of a bag to files: images as PNG, arrays as NPY, everything else as JSON Lines.

Each image or array message becomes ``<index:06d>_<log_time_ns>.png`` / ``.npy`` (raw byte
values ``.bin``); every other message becomes one line ``{"log_time_ns": ..., "value": ...}`` of
``messages.jsonl``. The formats are the logger's (``pyconnect.record.log_writer``), so exported
bags and live logs look alike. ``sensor_msgs/Image`` pixels in RGB(A) order (``rgb8``, ...) go
to PNG in the BGR(A) order OpenCV's PNG writer expects, so colours survive. Every file appears
atomically.
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import tempfile
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from pyconnect.errors import DecodeError
from pyconnect.record.bag_damage import BagDamage
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_reader import DecodeProblem, open_bag
from pyconnect.record.log_dirs import distinct_path_components
from pyconnect.record.log_values import (
    atomic_write_bytes,
    encode_log_value,
    in_native_byte_order,
    umask_mode,
)

__all__ = ["ExportResult", "export_topic", "export_topics", "topic_directories"]

JSONL_NAME = "messages.jsonl"
IMAGE_TYPE = "sensor_msgs/msg/Image"
_EXPORTED = re.compile(r"^\d{6}_\d+\.(png|npy|bin)$")
ProgressFactory = Callable[[int, str], Any]


@dataclass
class ExportResult:
    """What an export wrote: files per extension, undecodable messages, damage of the bag."""

    directory: Path
    files: Counter[str] = field(default_factory=Counter)
    errors: list[DecodeProblem] = field(default_factory=list)
    damage: list[BagDamage] = field(default_factory=list)
    damage_summary: str = ""

    @property
    def messages(self) -> int:
        return sum(self.files.values())


def _tqdm_progress(total: int, description: str) -> Any:
    from tqdm import tqdm

    return tqdm(
        total=total,
        desc=description,
        unit="msg",
        file=sys.stderr,
        disable=not sys.stderr.isatty(),
        leave=False,
    )


def _earlier_export(directory: Path) -> list[Path]:
    if not directory.is_dir():
        return []
    return sorted(p for p in directory.iterdir() if p.name == JSONL_NAME or _EXPORTED.match(p.name))


def _earlier_exports(directories: Sequence[Path], root: Path) -> list[Path]:
    """The files of earlier exports under ``root`` in either layout, those in ``directories``
    first: one topic writes into ``root``, several into its subdirectories, so an export of
    another number of topics would otherwise leave the earlier one beside it, mixed."""
    subdirectories = (
        sorted(p for p in root.iterdir() if p.is_dir() and not p.is_symlink())
        if root.is_dir()
        else []
    )
    places = dict.fromkeys([*directories, root, *subdirectories])
    return [path for place in places for path in _earlier_export(place)]


def topic_directories(topics: Sequence[str], to: str | Path) -> dict[str, Path]:
    """Where each topic goes: ``to`` itself for one topic, ``to/<topic as a name>`` for more.

    Topics whose names clean to the same folder name (``/a/b`` and ``/a__b``) get distinct
    folders (``a__b``, ``a__b_2``; ``log_dirs.distinct_path_components``), handed out in sorted
    topic order so that the order of ``--topic`` options does not change them.
    """
    root = Path(to)
    if len(topics) == 1:
        return {topics[0]: root}
    folders = distinct_path_components(sorted(topics))
    return {topic: root / folders[topic] for topic in topics}


def export_topics(
    path: str | Path,
    topics: Sequence[str],
    to: str | Path,
    *,
    natural: bool = True,
    force: bool = False,
    progress: ProgressFactory = _tqdm_progress,
) -> dict[str, ExportResult]:
    """Export several topics: one topic writes into ``to``, several into ``to/<topic>/``.

    An earlier export under ``to``, in either layout, raises ``BagError`` unless ``force``
    (its files are then removed first, so that no stale frame survives). Files get the
    permissions the umask gives (0644 with the usual 022).
    """
    chosen = list(dict.fromkeys(topics))
    if not chosen:
        raise BagError("export: no topic given")
    directories = topic_directories(chosen, to)
    earlier = _earlier_exports(list(directories.values()), Path(to))
    if earlier and not force:
        raise BagError(
            f"{earlier[0].parent}: already holds an export ({earlier[0].name}); "
            "use force=True (--force) to overwrite it"
        )
    with open_bag(path, topics=chosen):
        pass  # unknown topics and formats fail here, before anything is removed or written
    for old in earlier:
        old.unlink()
    for folder in {old.parent for old in earlier} - {Path(to)}:
        with contextlib.suppress(OSError):  # not empty: it holds files of the user's own
            folder.rmdir()  # a topic folder of the other layout; a target is made again
    results: dict[str, ExportResult] = {}
    for topic, directory in directories.items():
        results[topic] = export_topic(path, topic, directory, natural=natural, progress=progress)
    return results


def export_topic(
    path: str | Path,
    topic: str,
    to: str | Path,
    *,
    natural: bool = True,
    progress: ProgressFactory = _tqdm_progress,
) -> ExportResult:
    """Write every message of ``topic`` under ``to`` (created if needed); see the module doc.

    ``progress(total, description)`` makes a tqdm-like bar (``update``, ``close``); the default
    draws on stderr only when it is a terminal.
    """
    directory = Path(to)
    directory.mkdir(parents=True, exist_ok=True)
    result = ExportResult(directory)
    with open_bag(path, topics=[topic], natural=natural) as probe:
        is_image = natural and probe.topics[topic].msg_type == IMAGE_TYPE
    # Images are read as dicts so that their encoding (the channel order) is known.
    with open_bag(path, topics=[topic], natural=natural and not is_image) as bag:
        bar = progress(bag.topics[topic].message_count, topic)
        fd, temporary = tempfile.mkstemp(dir=directory, prefix=f".{JSONL_NAME}.", suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as lines:
                os.fchmod(lines.fileno(), umask_mode())
                for index, message in enumerate(bag):
                    value = message.value
                    if is_image:
                        try:
                            value = image_for_png(value)
                        except DecodeError as error:
                            problem = DecodeProblem(topic, index, message.log_time_ns, str(error))
                            result.errors.append(problem)
                            continue
                    extension, data = encode_log_value(value)
                    if extension == "json":
                        lines.write(b'{"log_time_ns": %d, "value": ' % message.log_time_ns)
                        lines.write(data)
                        lines.write(b"}\n")
                        result.files["jsonl"] += 1
                    else:
                        name = f"{index:06d}_{message.log_time_ns}.{extension}"
                        atomic_write_bytes(directory / name, data)
                        result.files[extension] += 1
                    bar.update(1)
            if result.files["jsonl"]:
                os.replace(temporary, directory / JSONL_NAME)
            else:
                os.unlink(temporary)
        except BaseException:
            if os.path.exists(temporary):
                os.unlink(temporary)
            raise
        finally:
            bar.close()
        result.errors[:0] = bag.errors
        result.damage = bag.damage
        if result.damage:
            result.damage_summary = bag.damage_summary()
    return result


def image_for_png(fields: dict[str, Any]) -> Any:
    """The pixels of an Image dict as an ndarray in native byte order (``cv2.imwrite`` takes no
    other; a big-endian ``mono16`` image decodes to ``>u2``), RGB(A) encodings turned to BGR(A)."""
    from pyconnect.codecs.image import decode_image

    pixels = in_native_byte_order(decode_image(SimpleNamespace(**fields)))
    encoding = str(fields.get("encoding", "")).lower()
    if encoding.startswith("rgba") and pixels.ndim == 3 and pixels.shape[2] == 4:
        return pixels[..., [2, 1, 0, 3]]
    if encoding.startswith("rgb") and pixels.ndim == 3 and pixels.shape[2] == 3:
        return pixels[..., ::-1]
    return pixels
