"""``align``: messages of several bag topics matched by timestamp, as message_filters does live.

``align(bag, ["/camera/image_raw", "/joint_states"], tolerance=0.02)`` yields one tuple per
match, one ``BagMessage`` per topic in the order given (``.value`` natural by default)::

    for image, joints in align("run1", ["/camera/image_raw", "/joint_states"], tolerance=0.02):
        train(image.value, joints.value)

``align_table(...)`` gives the same matches as one ``pyarrow.Table``: the columns of each
topic's ``to_arrow`` table, prefixed with the topic (``/joint_states.position``).

The rule is the one of rclpy's ``message_filters.ApproximateTimeSynchronizer(fs, queue_size,
slop)``, replayed over the bag in log-time order (the order messages arrived when recorded):

1. A message's time is its ``header.stamp`` (types without a header use the log time, as
   ``allow_headerless`` uses the arrival time). Each topic keeps the last ``queue_size``
   messages by time (a later message with the same time replaces the earlier one); a message
   older than every other in its full queue leaves it at once and matches nothing.
2. When a message arrives, each other topic's queued messages within ``tolerance`` of it
   (``|t - t_new| <= tolerance``) are candidates, nearest first; when some topic has none,
   nothing happens.
3. Combinations of candidates are tried in that order (the nearest of every topic first); the
   first whose times all lie within ``tolerance`` of each other (``max - min < tolerance``) is
   a match: it is yielded and its messages leave their queues.

So a match is made as soon as the last of its messages arrives, with the nearest messages
already received; a message is used in at most one match; messages never matched are dropped.
"""

from __future__ import annotations

import itertools
import math
import numbers
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any, TypeVar

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_reader import BagMessage, BagReader, open_bag
from pyconnect.record.topic_decoder import value_function

__all__ = ["align", "align_table", "match_stamps"]

Item = TypeVar("Item")

# Stamps are int64 nanoseconds (rosbag2's log times; a header's sec * 1e9 + nanosec): a
# tolerance needs a nanosecond count in that range too (1e300 s as ns overflows to inf).
_INT64_NS = float(2**63)


def match_stamps(
    arrivals: Iterable[tuple[int, int, Item]],
    *,
    topics: int,
    tolerance_ns: int,
    queue_size: int = 10,
) -> Iterator[tuple[Item, ...]]:
    """Match ``(queue index, stamp ns, item)`` arrivals by the rule in the module docstring."""
    if queue_size < 1:
        raise ValueError(f"queue_size: expected at least 1, got {queue_size}")
    queues: list[dict[int, Item]] = [{} for _ in range(topics)]
    for index, stamp, item in arrivals:
        mine = queues[index]
        mine[stamp] = item
        while len(mine) > queue_size:
            del mine[min(mine)]
        if stamp not in mine:
            # Its own stamp was the oldest of a full queue: the message is gone, so no match
            # can use it (message_filters skips every combination whose stamp left its queue).
            continue
        candidates: list[list[int]] = []
        for other_index, queue in enumerate(queues):
            if other_index == index:
                continue
            # Nearest first; equally near ones in the order they arrived (a stable sort over
            # the queue, as message_filters sorts by the distance alone).
            near = sorted(
                (other for other in queue if abs(other - stamp) <= tolerance_ns),
                key=lambda other: abs(other - stamp),
            )
            if not near:
                break
            candidates.append(near)
        else:
            for combination in itertools.product(*candidates):
                chosen = list(combination)
                chosen.insert(index, stamp)
                if max(chosen) - min(chosen) >= tolerance_ns:
                    continue
                yield tuple(queue[t] for queue, t in zip(queues, chosen, strict=True))
                for queue, t in zip(queues, chosen, strict=True):
                    del queue[t]
                break


def _stamp_ns(value: Any, log_time_ns: int) -> int:
    header = value.get("header") if isinstance(value, dict) else None
    stamp = header.get("stamp") if isinstance(header, dict) else None
    if not isinstance(stamp, dict):
        return log_time_ns
    return int(stamp["sec"]) * 1_000_000_000 + int(stamp["nanosec"])


def _arrivals(
    reader: BagReader, topics: Sequence[str]
) -> Iterator[tuple[int, int, tuple[int, BagMessage, Any]]]:
    """Each message as ``(topic index, stamp, (row of its topic, message, its codec))``."""
    position = {topic: index for index, topic in enumerate(topics)}
    counts = [0] * len(topics)
    for message, codec in reader.with_codecs():
        index = position[message.topic]
        row = counts[index]
        counts[index] += 1
        yield index, _stamp_ns(message.value, message.log_time_ns), (row, message, codec)


def _check(topics: Sequence[str], tolerance: float, queue_size: int) -> list[str]:
    chosen = [topics] if isinstance(topics, str) else list(topics)
    if len(chosen) < 2 or len(set(chosen)) != len(chosen):
        raise ValueError(f"topics: expected two or more different topics, got {chosen!r}")
    # bool is an int, but True seconds is a slip, as it is for the bag's start_ns.
    if isinstance(tolerance, bool) or not isinstance(tolerance, numbers.Real):
        raise TypeError(
            f"tolerance: expected seconds (a real number) > 0, got "
            f"{type(tolerance).__name__} ({tolerance!r:.80})"
        )
    if not tolerance > 0:  # written so that NaN fails too
        raise ValueError(f"tolerance: expected seconds > 0, got {tolerance!r}")
    if tolerance == math.inf:  # no nanosecond count to compare stamps with
        raise ValueError(f"tolerance: expected finite seconds, got {tolerance!r}")
    try:
        # As a float first: a numpy float32's own product would overflow (with a warning).
        nanoseconds = float(tolerance) * 1e9
    except OverflowError:  # an int beyond every float
        nanoseconds = math.inf
    if not nanoseconds < _INT64_NS:  # finite seconds whose nanoseconds overflow
        raise ValueError(
            f"tolerance: expected seconds < {_INT64_NS / 1e9} (int64 nanoseconds), "
            f"got {tolerance!r:.80}"
        )
    if isinstance(queue_size, bool) or not isinstance(queue_size, numbers.Integral):
        raise TypeError(f"queue_size: expected an int >= 1, got {type(queue_size).__name__}")
    if queue_size < 1:
        raise ValueError(f"queue_size: expected at least 1, got {queue_size}")
    return chosen


def align(
    bag: str | Path,
    topics: Sequence[str],
    *,
    tolerance: float,
    queue_size: int = 10,
    natural: bool = True,
) -> Iterator[tuple[BagMessage, ...]]:
    """Yield matched messages of ``topics`` (``tolerance`` in seconds): see the module docstring.

    The options are checked at the call, before the first match is asked for.
    """
    chosen = _check(topics, tolerance, queue_size)
    return _align(bag, chosen, tolerance=tolerance, queue_size=queue_size, natural=natural)


def _align(
    bag: str | Path, chosen: list[str], *, tolerance: float, queue_size: int, natural: bool
) -> Iterator[tuple[BagMessage, ...]]:
    with open_bag(bag, topics=chosen, natural=False) as reader:
        naturals: dict[int, Callable[[Any], Any]] = {}
        for match in match_stamps(
            _arrivals(reader, chosen),
            topics=len(chosen),
            tolerance_ns=round(tolerance * 1e9),
            queue_size=queue_size,
        ):
            if not natural:
                yield tuple(message for _row, message, _codec in match)
                continue
            yield tuple(
                _natural(reader, message, codec, naturals) for _row, message, codec in match
            )


def _natural(
    reader: BagReader,
    message: BagMessage,
    codec: Any,
    naturals: dict[int, Callable[[Any], Any]],
) -> BagMessage:
    """``message`` (a lossless dict) with the natural value ``open_bag`` gives for it.

    The stamps need the dicts, and only matched messages need natural values: the dict goes
    back to CDR through ``codec``, the one the reader decoded it with (its connection's: the
    bag's own definition, or the installed type where that did not fit; a topic stored with
    two definitions has two), which is lossless, and that codec decodes it again.
    """
    if codec is None:  # nothing could decode the message, so it never gets here
        raise BagError(f"{reader.path}: {message.topic}: no codec for {message.msg_type}")
    decode = naturals.get(id(codec))
    if decode is None:
        decode = naturals[id(codec)] = value_function(codec, natural=True)
    return BagMessage(
        message.topic, message.log_time_ns, decode(codec.from_dict(message.value)), message.msg_type
    )


def align_table(
    bag: str | Path,
    topics: Sequence[str],
    *,
    tolerance: float,
    queue_size: int = 10,
) -> Any:
    """The matches of ``align`` as one ``pyarrow.Table`` (columns ``<topic>.<column>``)."""
    import pyarrow as pa

    from pyconnect.record.tables import topic_table

    chosen = _check(topics, tolerance, queue_size)
    with open_bag(bag, topics=chosen, natural=False) as reader:
        rows = [
            [row for row, _message, _codec in match]
            for match in match_stamps(
                _arrivals(reader, chosen),
                topics=len(chosen),
                tolerance_ns=round(tolerance * 1e9),
                queue_size=queue_size,
            )
        ]
        tables = [topic_table(reader, topic) for topic in chosen]
    arrays: list[Any] = []
    names: list[str] = []
    for index, (topic, table) in enumerate(zip(chosen, tables, strict=True)):
        taken = table.take(pa.array([match[index] for match in rows], type=pa.int64()))
        arrays.extend(taken.columns)
        names.extend(f"{topic}.{name}" for name in table.schema.names)
    return pa.Table.from_arrays(arrays, names=names)
