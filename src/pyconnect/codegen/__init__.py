"""codecgen: renders ROS interface definitions (the type model) into straight-line codec modules.

The renderer (``render``, ``wire_render``, ``templating`` and the templates) is pure: type model
in, source text out; the registry uses it to compile codecs on the fly. The ``codecgen`` command
(``cli``, ``build``) sits on top and writes files.
"""

from __future__ import annotations

from pyconnect.typesys.errors import DefinitionError

__all__ = ["FORMAT_VERSION", "DefinitionError"]

FORMAT_VERSION = "1"
