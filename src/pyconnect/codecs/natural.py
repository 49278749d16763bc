"""The table of natural codecs (DESIGN.md §4): which type gets which codec, imported on first use."""

from __future__ import annotations

# "pkg/msg/Name" -> "module:factory". The factory takes no arguments and returns a Codec.
# Importing lazily keeps `import pyconnect.codecs` free of numpy/OpenCV until a codec is used.
NATURAL_CODECS: dict[str, str] = {}
