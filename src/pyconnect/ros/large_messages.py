"""Fast DDS set up for large messages (images, point clouds) before the first node starts.

Stock Fast DDS sends a 1080p image between two processes in 30-35 ms and a best-effort reader
loses most of them (UDP fragments; docs/ros-facts.md). A shared-memory transport whose segment holds
the largest message, plus glibc malloc settings that stop page-fault storms on every multi-MB
buffer, bring it to about 4 ms. ``pyconnect run script.py`` does both for a program, and so does
importing ``pyconnect.ros`` when ``PYCONNECT_LARGE_MESSAGES=1``:

- writes a Fast DDS XML profile (a shared-memory transport with a ``PYCONNECT_SHM_SEGMENT_MB``
  segment, 64 MiB by default, beside UDPv4 for other hosts) into a directory only this user can
  write (``profile_directory``) and points ``FASTRTPS_DEFAULT_PROFILES_FILE`` at it — Fast DDS
  reads it when the first node of the process is created, so import pyconnect before creating
  rclpy nodes yourself;
- calls glibc's ``mallopt`` with the values of ``MALLOC_MMAP_THRESHOLD_=268435456`` and
  ``MALLOC_TRIM_THRESHOLD_=1073741824``, each only when its variable is not set (the user's own
  value was read by glibc at start; ``pyconnect run script.py`` sets the variables before the
  interpreter starts, which also covers what was allocated before the import).

Fast DDS's data-sharing is left at its default (automatic): it refuses data-sharing for
unbounded types such as Image and PointCloud2, which therefore travel through the shared-memory
transport in 64 KB fragments (the delivery stage of ``bench.large_messages``).

Not on at plain import: it gives the process a shared-memory segment and changes its malloc,
a choice for the program's owner (``pyconnect run``, or the variable), not a side effect.
Nothing is changed when the user set a Fast DDS profile (``FASTRTPS_DEFAULT_PROFILES_FILE`` /
``FASTDDS_DEFAULT_PROFILES_FILE`` naming a file other than pyconnect's own
``pyconnect-fastdds-<digest>.xml``, or a ``DEFAULT_FASTRTPS_PROFILES.xml`` in the working
directory) or another ``RMW_IMPLEMENTATION``, when ``/dev/shm`` cannot hold four segments (small
containers), or when the profile cannot be written (its private directory's name is taken by
someone else). ``PYCONNECT_LARGE_MESSAGES=0`` changes nothing either, except that it removes
what a pyconnect before it (a ``pyconnect run`` parent) put in the environment: the variable
naming pyconnect's own profile and the malloc variables ``PYCONNECT_MALLOC_SET`` lists. A
``PYCONNECT_SHM_SEGMENT_MB`` that is no size from 8 to 3584 MiB is an error for
``pyconnect run`` and a warning on the ``pyconnect.ros`` logger at import (nothing is changed
then).
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import hashlib
import logging
import math
import os
import re
import shutil
import stat
import tempfile
from collections.abc import Collection, MutableMapping
from fractions import Fraction
from pathlib import Path

from pyconnect.errors import PyconnectError

_log = logging.getLogger("pyconnect.ros")

MALLOC_SETTINGS = {
    "MALLOC_MMAP_THRESHOLD_": "268435456",
    "MALLOC_TRIM_THRESHOLD_": "1073741824",
}
"""glibc's environment variables and the values pyconnect uses (bytes)."""

DEFAULT_SEGMENT_MB = 64
"""Shared-memory segment per process: room for 5 queued 1080p frames, 2 of 4K or 5 x 10 MB clouds.

Fast DDS writes the whole segment when it creates it, so each process holds this much RAM in
``/dev/shm``, and a process that dies without shutting down leaves it there: 256 MiB filled a
24 GB ``/dev/shm`` during a benchmark run. 16, 32, 64 and 256 MiB gave the same 1080p latency
(the frame is copied out of the segment as it arrives). ``PYCONNECT_SHM_SEGMENT_MB`` changes it.
"""

_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
_MALLOPT_MMAP_MAX = 32 * 1024 * 1024
_SHM_HEADROOM = 4  # segments /dev/shm must have room for (two peers, each with margin)
_MIB = 1024 * 1024
MIN_SEGMENT_MB = 8
"""The smallest ``PYCONNECT_SHM_SEGMENT_MB``: one 1080p rgb8 frame (5.9 MiB) and room beside it,
the least a segment for large messages is worth its ``/dev/shm`` for."""
MAX_SEGMENT_MB = 3584
"""The largest ``PYCONNECT_SHM_SEGMENT_MB`` (3.5 GiB).

Fast DDS 2.14 reads ``segment_size`` as a 32-bit unsigned number and adds its bookkeeping to it
in 32 bits too: a buffer node and an allocator header for each KiB of segment (it plans one
allocation per 1 KiB), about 5 % more. 4096 MiB wraps to no segment, 5000 to 904 MiB, and 4000
(2.3 % below 2**32) already fails to allocate. 3584 MiB leaves 512 MiB, room for 146 bytes of
bookkeeping per KiB.
"""
_MIN_SEGMENT = MIN_SEGMENT_MB * _MIB
_MAX_SEGMENT = MAX_SEGMENT_MB * _MIB
MALLOC_MARKER = "PYCONNECT_MALLOC_SET"
"""Names the ``MALLOC_SETTINGS`` variables pyconnect set (space-separated), so that
``PYCONNECT_LARGE_MESSAGES=0`` in a child process can tell them from values of the user's."""
_OFF = frozenset({"0", "false", "no", "off"})
_PROFILE_VARIABLES = ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE")
_CWD_PROFILE = "DEFAULT_FASTRTPS_PROFILES.xml"
"""The profile Fast DDS 2.14 also loads from the working directory (Fast DDS 3 renamed it
``DEFAULT_FASTDDS_PROFILES.xml``; Jazzy's 2.14 reads only this name); its default participant
profile wins over the one the variable names."""


class SegmentSizeError(PyconnectError, ValueError):
    """``PYCONNECT_SHM_SEGMENT_MB`` holds no usable size; the message names it and its value."""


def profile_xml(segment_bytes: int) -> str:
    """The Fast DDS profile: shared memory (``segment_bytes``) first, UDPv4 for other hosts."""
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<!-- Written by pyconnect (pyconnect.ros.large_messages). PYCONNECT_LARGE_MESSAGES=0 disables. -->
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <transport_descriptors>
    <transport_descriptor>
      <transport_id>pyconnect_shm</transport_id>
      <type>SHM</type>
      <segment_size>{segment_bytes}</segment_size>
    </transport_descriptor>
    <transport_descriptor>
      <transport_id>pyconnect_udp</transport_id>
      <type>UDPv4</type>
    </transport_descriptor>
  </transport_descriptors>
  <participant profile_name="pyconnect_large_messages" is_default_profile="true">
    <rtps>
      <userTransports>
        <transport_id>pyconnect_shm</transport_id>
        <transport_id>pyconnect_udp</transport_id>
      </userTransports>
      <useBuiltinTransports>false</useBuiltinTransports>
    </rtps>
  </participant>
</profiles>
"""


def wanted_segment_bytes(environ: MutableMapping[str, str] | None = None) -> int:
    """``PYCONNECT_SHM_SEGMENT_MB`` in bytes (64 MiB when unset or empty).

    Raises ``SegmentSizeError`` unless it is a number of MiB from ``MIN_SEGMENT_MB`` to
    ``MAX_SEGMENT_MB``.
    """
    env = os.environ if environ is None else environ
    text = env.get("PYCONNECT_SHM_SEGMENT_MB", "")
    if not text.strip():
        return DEFAULT_SEGMENT_MB * _MIB
    try:
        megabytes = float(text)
    except ValueError:
        megabytes = math.nan
    # NaN fails both comparisons.
    if not MIN_SEGMENT_MB <= megabytes <= MAX_SEGMENT_MB:
        raise SegmentSizeError(
            "PYCONNECT_SHM_SEGMENT_MB: expected a segment size in MiB, a number from "
            f"{MIN_SEGMENT_MB} to {MAX_SEGMENT_MB} ({DEFAULT_SEGMENT_MB} by default), got {text!r}"
        )
    return int(Fraction(megabytes) * _MIB)


def segment_bytes(environ: MutableMapping[str, str] | None = None) -> int:
    """The segment size: ``PYCONNECT_SHM_SEGMENT_MB`` or 64 MiB, shrunk to fit ``/dev/shm``
    (a quarter of its free space) and never above ``MAX_SEGMENT_MB``.

    Raises ``SegmentSizeError`` for a ``PYCONNECT_SHM_SEGMENT_MB`` that is no usable size.
    """
    wanted = wanted_segment_bytes(environ)
    try:
        free = shutil.disk_usage("/dev/shm").free
    except OSError:
        return 0
    return min(wanted, free // _SHM_HEADROOM, _MAX_SEGMENT)


def disabled_because(
    environ: MutableMapping[str, str] | None = None, *, default_on: bool = False
) -> str | None:
    """Why pyconnect leaves Fast DDS alone in this environment, or None.

    ``default_on``: on unless ``PYCONNECT_LARGE_MESSAGES`` says off (``pyconnect run``);
    otherwise (at import) only when it says on.
    """
    env = os.environ if environ is None else environ
    if _is_off(env):
        return "PYCONNECT_LARGE_MESSAGES is off"
    setting = env.get("PYCONNECT_LARGE_MESSAGES", "").strip().lower()
    if not default_on and setting not in {"1", "true", "yes", "on"}:
        return "PYCONNECT_LARGE_MESSAGES is not set (pyconnect run sets it)"
    for name in _PROFILE_VARIABLES:
        if env.get(name) and not is_own_profile(env[name]):
            return f"{name} is set"
    # Fast DDS reads it from the directory it runs in unless SKIP_DEFAULT_XML_FILE=1.
    if env.get("SKIP_DEFAULT_XML_FILE") != "1" and os.path.isfile(_CWD_PROFILE):
        return f"{_CWD_PROFILE} is in the working directory"
    # Empty is unset for rclpy too: it loads its default, Fast DDS.
    rmw = env.get("RMW_IMPLEMENTATION") or "rmw_fastrtps_cpp"
    if rmw not in {"rmw_fastrtps_cpp", "rmw_fastrtps_dynamic_cpp"}:
        return f"RMW_IMPLEMENTATION is {rmw}"
    return None


def _is_off(environ: MutableMapping[str, str]) -> bool:
    """True when ``PYCONNECT_LARGE_MESSAGES`` turns the settings off."""
    return environ.get("PYCONNECT_LARGE_MESSAGES", "").strip().lower() in _OFF


_OWN_PROFILE = re.compile(r"pyconnect-fastdds-[0-9a-f]{12}\.xml")


def is_own_profile(path: str) -> bool:
    """True for a profile ``write_profile`` wrote: the variable naming it was set by pyconnect
    (importing ``pyconnect.ros`` in this process, or a ``pyconnect run`` before it), which is
    no user's choice of profile to leave alone."""
    return _OWN_PROFILE.fullmatch(Path(path).name) is not None


def profile_directory() -> Path:
    """This user's private directory for the profile: ``$XDG_RUNTIME_DIR`` when it is a
    directory of this user's that no one else may enter, else ``pyconnect-<uid>`` in the temp
    directory, created with mode 0700.

    Raises ``PermissionError`` when that name is taken by anything but such a directory: the
    temp directory is world-writable, and a profile another user can replace would let them
    choose this user's DDS transports (peers to send to, for one).
    """
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    # The XDG spec says a relative one is to be ignored; it would also name another file once
    # the program changes directory before its first node.
    if runtime and os.path.isabs(runtime) and _not_private_because(Path(runtime)) is None:
        return Path(runtime)
    # absolute(): gettempdir() keeps a TMPDIR of "." as it is.
    directory = Path(tempfile.gettempdir()).absolute() / f"pyconnect-{os.getuid()}"
    with contextlib.suppress(FileExistsError):
        directory.mkdir(mode=0o700)
    problem = _not_private_because(directory)
    if problem is not None:
        raise PermissionError(f"{directory} {problem}, so it cannot hold pyconnect's profile")
    return directory


def _not_private_because(directory: Path) -> str | None:
    """Why ``directory`` is no directory of this user's closed to others, or None."""
    try:
        status = os.lstat(directory)  # lstat: a symlink may point anywhere, someone else's too
    except OSError as error:
        return f"cannot be examined ({error.strerror})"
    if not stat.S_ISDIR(status.st_mode):
        return "is not a directory"
    if status.st_uid != os.getuid():
        return f"belongs to user {status.st_uid}, expected {os.getuid()}"
    if status.st_mode & 0o077:
        return f"has mode {stat.S_IMODE(status.st_mode):o}, expected 700"
    return None


def write_profile(segment: int) -> Path:
    """Write the profile once per segment size (shared by this user's processes) into
    ``profile_directory()`` and return its path; ``OSError`` when it cannot be written."""
    text = profile_xml(segment)
    digest = hashlib.sha256(text.encode()).hexdigest()[:12]
    directory = profile_directory()
    path = directory / f"pyconnect-fastdds-{digest}.xml"
    if _read_regular_file(path) == text:
        return path
    # Written aside under an unpredictable name and renamed: another process may read it at
    # the same moment, and a fixed name could be taken by a file or link of someone else's.
    descriptor, partial = tempfile.mkstemp(prefix=f"{path.stem}.", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(descriptor, "w", encoding="utf-8") as file:
            file.write(text)
        os.replace(partial, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(partial)
        raise
    return path


def _read_regular_file(path: Path) -> str | None:
    """The text of ``path`` when it is a file (not a symlink), else None."""
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError:
        return None
    try:
        with os.fdopen(descriptor, encoding="utf-8") as file:
            return file.read() if stat.S_ISREG(os.fstat(file.fileno()).st_mode) else None
    except (OSError, UnicodeDecodeError):
        return None


def configure_environment(
    environ: MutableMapping[str, str], *, default_on: bool = False
) -> str | None:
    """Set the profile and malloc variables in ``environ``; the reason it did not, or None.

    With ``PYCONNECT_LARGE_MESSAGES`` off, what a pyconnect before it set (this environment
    was inherited from a ``pyconnect run`` program) is removed instead: off means off for
    the programs that program starts too.

    Raises ``SegmentSizeError`` (``environ`` unchanged) for a ``PYCONNECT_SHM_SEGMENT_MB`` that
    is no usable size.
    """
    reason = disabled_because(environ, default_on=default_on)
    if reason is not None:
        if _is_off(environ):
            _remove_inherited_settings(environ)
        return reason
    segment = segment_bytes(environ)
    if segment < _MIN_SEGMENT:
        return "/dev/shm has too little room for a shared-memory segment"
    try:
        profile = write_profile(segment)
    except OSError as error:
        return f"the Fast DDS profile could not be written: {error}"
    environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(profile)
    environ["PYCONNECT_LARGE_MESSAGES"] = "1"
    ours = _malloc_set_by_pyconnect(environ)
    for name, value in MALLOC_SETTINGS.items():
        if name not in environ:
            environ[name] = value
            ours.append(name)
    if ours:
        environ[MALLOC_MARKER] = " ".join(name for name in MALLOC_SETTINGS if name in ours)
    return None


def _malloc_set_by_pyconnect(environ: MutableMapping[str, str]) -> list[str]:
    """The malloc variables ``MALLOC_MARKER`` lists that still hold pyconnect's value (one
    given another value since is the user's)."""
    listed = environ.get(MALLOC_MARKER, "").split()
    return [
        name
        for name in MALLOC_SETTINGS
        if name in listed and environ.get(name) == MALLOC_SETTINGS[name]
    ]


def _remove_inherited_settings(environ: MutableMapping[str, str]) -> None:
    """Remove what a pyconnect set in an environment this one inherited: the variable naming
    pyconnect's own profile, and the malloc variables pyconnect set (``MALLOC_MARKER``)."""
    for name in _PROFILE_VARIABLES:
        if environ.get(name) and is_own_profile(environ[name]):
            del environ[name]
    for name in _malloc_set_by_pyconnect(environ):
        del environ[name]
    environ.pop(MALLOC_MARKER, None)


_outcome: dict[str, str | None] = {}


def configure() -> str | None:
    """Configure this process (once): profile for Fast DDS, ``mallopt`` for glibc.

    Returns None when configured, else why not.
    """
    if "reason" not in _outcome:
        unset = [name for name in MALLOC_SETTINGS if name not in os.environ]
        try:
            _outcome["reason"] = configure_environment(os.environ)
        except SegmentSizeError as error:
            # An import must not fail over a tuning variable; the user asked for the settings
            # (PYCONNECT_LARGE_MESSAGES=1), so they hear why they are off.
            _outcome["reason"] = str(error)
            _log.warning("large-message settings not applied: %s", error)
        if _outcome["reason"] is None:
            _apply_mallopt(unset)
    return _outcome["reason"]


def apply_malloc_settings() -> None:
    """The glibc malloc settings alone, for a process without DDS (a zenoh ``Peer``): a 1080p
    image between two peers took 14-40 ms p50 with page-fault storms, 4 ms without. Nothing
    when ``PYCONNECT_LARGE_MESSAGES`` is off or the variables were set at process start."""
    if "malloc" in _outcome:
        return
    _outcome["malloc"] = None
    if _is_off(os.environ):
        return
    _apply_mallopt([name for name in MALLOC_SETTINGS if name not in os.environ])


def _apply_mallopt(names: Collection[str]) -> None:
    """Apply the malloc settings ``names`` now (glibc only reads the variables at process
    start); the others were set by the user, whose values glibc already took."""
    if not names:
        return
    name = ctypes.util.find_library("c")
    if name is None:
        return
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc (musl, macOS)
        return
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    if "MALLOC_TRIM_THRESHOLD_" in names:
        mallopt(_M_TRIM_THRESHOLD, int(MALLOC_SETTINGS["MALLOC_TRIM_THRESHOLD_"]))
    if "MALLOC_MMAP_THRESHOLD_" in names and not mallopt(
        _M_MMAP_THRESHOLD, int(MALLOC_SETTINGS["MALLOC_MMAP_THRESHOLD_"])
    ):
        # mallopt refuses more than half glibc's heap size (32 MiB on 64-bit); take that.
        mallopt(_M_MMAP_THRESHOLD, _MALLOPT_MMAP_MAX)
