"""Fast DDS set up for large messages (images, point clouds) before the first node starts.

Stock Fast DDS sends a 1080p image between two processes in 30-35 ms and a best-effort reader
loses most of them (UDP fragments; docs/ros-facts.md). A shared-memory transport whose segment holds
the largest message, plus glibc malloc settings that stop page-fault storms on every multi-MB
buffer, bring it to about 4 ms. ``pyconnect run script.py`` does both for a program, and so does
importing ``pyconnect.ros`` when ``PYCONNECT_LARGE_MESSAGES=1``:

- writes a Fast DDS XML profile (a shared-memory transport with a ``PYCONNECT_SHM_SEGMENT_MB``
  segment, 64 MiB by default, beside UDPv4 for other hosts) and points
  ``FASTRTPS_DEFAULT_PROFILES_FILE`` at it — Fast DDS reads it when the first node of the
  process is created, so import pyconnect before creating rclpy nodes yourself;
- calls glibc's ``mallopt`` with the values of ``MALLOC_MMAP_THRESHOLD_=268435456`` and
  ``MALLOC_TRIM_THRESHOLD_=1073741824`` (``pyconnect run script.py`` sets the variables before
  the interpreter starts, which also covers what was allocated before the import).

Fast DDS's data-sharing is left at its default (automatic): it refuses data-sharing for
unbounded types such as Image and PointCloud2, which therefore travel through the shared-memory
transport in 64 KB fragments (the delivery stage of ``bench.large_messages``).

Not on at plain import: it gives the process a shared-memory segment and changes its malloc,
a choice for the program's owner (``pyconnect run``, or the variable), not a side effect.
Nothing is changed when ``PYCONNECT_LARGE_MESSAGES=0``, when the user set a Fast DDS profile
(``FASTRTPS_DEFAULT_PROFILES_FILE`` / ``FASTDDS_DEFAULT_PROFILES_FILE`` naming a file other
than pyconnect's own ``pyconnect-fastdds-<digest>.xml``) or another
``RMW_IMPLEMENTATION``, or when ``/dev/shm`` cannot hold four segments (small containers).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import hashlib
import os
import re
import shutil
import tempfile
from collections.abc import MutableMapping
from pathlib import Path

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


def segment_bytes(environ: MutableMapping[str, str] | None = None) -> int:
    """The segment size: ``PYCONNECT_SHM_SEGMENT_MB`` or 64 MiB, shrunk to fit ``/dev/shm``."""
    env = os.environ if environ is None else environ
    wanted = int(float(env.get("PYCONNECT_SHM_SEGMENT_MB", DEFAULT_SEGMENT_MB)) * 1024 * 1024)
    try:
        free = shutil.disk_usage("/dev/shm").free
    except OSError:
        return 0
    return min(wanted, free // _SHM_HEADROOM)


def disabled_because(
    environ: MutableMapping[str, str] | None = None, *, default_on: bool = False
) -> str | None:
    """Why pyconnect leaves Fast DDS alone in this environment, or None.

    ``default_on``: on unless ``PYCONNECT_LARGE_MESSAGES`` says off (``pyconnect run``);
    otherwise (at import) only when it says on.
    """
    env = os.environ if environ is None else environ
    setting = env.get("PYCONNECT_LARGE_MESSAGES", "").strip().lower()
    if setting in {"0", "false", "no", "off"}:
        return "PYCONNECT_LARGE_MESSAGES is off"
    if not default_on and setting not in {"1", "true", "yes", "on"}:
        return "PYCONNECT_LARGE_MESSAGES is not set (pyconnect run sets it)"
    for name in ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE"):
        if env.get(name) and not is_own_profile(env[name]):
            return f"{name} is set"
    rmw = env.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    if rmw not in {"rmw_fastrtps_cpp", "rmw_fastrtps_dynamic_cpp"}:
        return f"RMW_IMPLEMENTATION is {rmw}"
    return None


_OWN_PROFILE = re.compile(r"pyconnect-fastdds-[0-9a-f]{12}\.xml")


def is_own_profile(path: str) -> bool:
    """True for a profile ``write_profile`` wrote: the variable naming it was set by pyconnect
    (importing ``pyconnect.ros`` in this process, or a ``pyconnect run`` before it), which is
    no user's choice of profile to leave alone."""
    return _OWN_PROFILE.fullmatch(Path(path).name) is not None


def write_profile(segment: int) -> Path:
    """Write the profile once per segment size (shared by processes) and return its path."""
    text = profile_xml(segment)
    digest = hashlib.sha256(text.encode()).hexdigest()[:12]
    path = Path(tempfile.gettempdir()) / f"pyconnect-fastdds-{digest}.xml"
    if not path.exists():
        # Written aside and renamed: another process may read it at the same moment.
        partial = path.with_suffix(f".{os.getpid()}.tmp")
        partial.write_text(text)
        partial.replace(path)
    return path


def configure_environment(
    environ: MutableMapping[str, str], *, default_on: bool = False
) -> str | None:
    """Set the profile and malloc variables in ``environ``; the reason it did not, or None."""
    reason = disabled_because(environ, default_on=default_on)
    if reason is not None:
        return reason
    segment = segment_bytes(environ)
    if segment < 8 * 1024 * 1024:
        return "/dev/shm has too little room for a shared-memory segment"
    environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(write_profile(segment))
    environ["PYCONNECT_LARGE_MESSAGES"] = "1"
    for name, value in MALLOC_SETTINGS.items():
        environ.setdefault(name, value)
    return None


_outcome: dict[str, str | None] = {}


def configure() -> str | None:
    """Configure this process (once): profile for Fast DDS, ``mallopt`` for glibc.

    Returns None when configured, else why not.
    """
    if "reason" not in _outcome:
        had_malloc_env = all(name in os.environ for name in MALLOC_SETTINGS)
        _outcome["reason"] = configure_environment(os.environ)
        if _outcome["reason"] is None and not had_malloc_env:
            _apply_mallopt()
    return _outcome["reason"]


def apply_malloc_settings() -> None:
    """The glibc malloc settings alone, for a process without DDS (a zenoh ``Peer``): a 1080p
    image between two peers took 14-40 ms p50 with page-fault storms, 4 ms without. Nothing
    when ``PYCONNECT_LARGE_MESSAGES`` is off or the variables were set at process start."""
    if "malloc" in _outcome:
        return
    _outcome["malloc"] = None
    setting = os.environ.get("PYCONNECT_LARGE_MESSAGES", "").strip().lower()
    if setting in {"0", "false", "no", "off"}:
        return
    if not all(name in os.environ for name in MALLOC_SETTINGS):
        _apply_mallopt()


def _apply_mallopt() -> None:
    """Apply the malloc settings now (glibc only reads the variables at process start)."""
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
    mallopt(_M_TRIM_THRESHOLD, int(MALLOC_SETTINGS["MALLOC_TRIM_THRESHOLD_"]))
    if not mallopt(_M_MMAP_THRESHOLD, int(MALLOC_SETTINGS["MALLOC_MMAP_THRESHOLD_"])):
        # mallopt refuses more than half glibc's heap size (32 MiB on 64-bit); take that.
        mallopt(_M_MMAP_THRESHOLD, _MALLOPT_MMAP_MAX)
