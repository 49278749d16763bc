"""What ``open_bag`` checks of its arguments when the bag is opened: ``registry=``, and the
``start_ns``/``end_ns`` time bounds as int64 nanoseconds."""

from __future__ import annotations

import datetime
import operator
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from pyconnect.codecs.registry import Registry

_INT64 = (-(2**63), 2**63 - 1)
_EPOCH = datetime.datetime(1970, 1, 1, tzinfo=datetime.timezone.utc)
_MICROSECOND = datetime.timedelta(microseconds=1)
_EXPECTED = "expected int nanoseconds or a timezone-aware datetime"

TimeBound = int | datetime.datetime  # a start_ns/end_ns: nanoseconds, or an aware datetime


def checked_registry(value: object) -> Registry | None:
    """``registry=`` checked when the bag is opened: anything but a ``Registry`` (or None, the
    default registry) otherwise failed every message of the read, one by one."""
    if value is None:
        return None
    # Imported here: a bag read with the default registry leaves the codecs' registry module
    # to be imported when the first value is decoded, as before.
    from pyconnect.codecs.registry import Registry

    if not isinstance(value, Registry):
        raise TypeError(
            "registry: expected a pyconnect.codecs.Registry (or None for the default "
            f"registry), got {type(value).__name__} ({value!r:.80})"
        )
    return value


def nanoseconds(option: str, value: TimeBound | None) -> int | None:
    """``value`` of ``option`` (start_ns, end_ns) as int64 nanoseconds; TypeError if it is neither.

    Checked when the bag is opened: unchecked, a str or datetime selected nothing or everything
    of a .db3 file and raised mid-read of an MCAP one, and 2**70 overflowed SQLite's integers.
    """
    if value is None:
        return None
    if isinstance(value, datetime.datetime):
        if value.utcoffset() is None:
            raise TypeError(
                f"{option}: {_EXPECTED}, got a naive datetime ({value.isoformat()}), "
                "which does not say which instant it is"
            )
        # Exact: a datetime counts whole microseconds.
        nanoseconds = (value - _EPOCH) // _MICROSECOND * 1000
    elif isinstance(value, bool):
        raise TypeError(f"{option}: {_EXPECTED}, got bool ({value!r})")
    else:
        try:
            nanoseconds = operator.index(value)  # int and numpy integers, not floats or str
        except TypeError:
            raise TypeError(
                f"{option}: {_EXPECTED}, got {type(value).__name__} ({value!r:.80})"
            ) from None
    return min(max(nanoseconds, _INT64[0]), _INT64[1])
