"""Format rendered modules with ruff (line length 100), so that generated/ reads like our code.

Formatting is part of ``codecgen build`` and ``codecgen check`` (deterministic for one ruff
version). Without ruff installed (it comes with the ``dev`` extra) the output is the same code,
unformatted. Code compiled on the fly is never written and is not formatted.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import tempfile
from pathlib import Path

from pyconnect.typesys.errors import DefinitionError

LINE_LENGTH = 100


def format_modules(files: dict[str, str]) -> dict[str, str]:
    """The same files with every ``.py`` one formatted by ``ruff format`` (one ruff run)."""
    python = sorted(name for name in files if name.endswith(".py"))
    if not python or importlib.util.find_spec("ruff") is None:
        return dict(files)
    with tempfile.TemporaryDirectory(prefix="codecgen-") as folder:
        root = Path(folder)
        for name in python:
            path = root / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(files[name], encoding="utf-8")
        command = [sys.executable, "-m", "ruff", "format", "--isolated", "--quiet",
                   "--line-length", str(LINE_LENGTH), "--target-version", "py310", "."]  # fmt: skip
        try:
            subprocess.run(command, cwd=root, check=True, capture_output=True, text=True)
        except FileNotFoundError as error:
            raise DefinitionError(f"cannot run ruff to format the output ({error})") from None
        except subprocess.CalledProcessError as error:
            detail = " ".join((error.stderr or error.stdout or "").split()) or "no message"
            raise DefinitionError(f"ruff could not format the output: {detail}") from None
        formatted = {name: (root / name).read_text(encoding="utf-8") for name in python}
    return {name: formatted.get(name, text) for name, text in files.items()}
