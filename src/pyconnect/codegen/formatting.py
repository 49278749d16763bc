"""Format rendered modules with ruff (line length 100), so that generated/ reads like our code.

Formatting is part of ``codecgen build`` and ``codecgen check`` (deterministic for one ruff
version). Without ruff installed (it comes with the ``dev`` extra) the output is the same code,
unformatted, and ``same_module`` compares modules in a form formatting does not change. Code
compiled on the fly is never written and is not formatted.
"""

from __future__ import annotations

import ast
import importlib.util
import io
import subprocess
import sys
import tempfile
import tokenize
from pathlib import Path

from pyconnect.typesys.errors import DefinitionError

LINE_LENGTH = 100


def formatter_available() -> bool:
    """Whether ``format_modules`` formats (ruff is installed) or returns the text as rendered."""
    return importlib.util.find_spec("ruff") is not None


def same_module(name: str, rendered: str, written: str) -> bool:
    """Whether ``written`` (a file on disk) is what a build writes as ``rendered`` for ``name``.

    With ruff installed, byte for byte: ``rendered`` was formatted as the files were. Without it
    (an install without the ``dev`` extra), ``rendered`` is unformatted while the files a wheel
    or a checkout holds were formatted, and bytes would call every one of them stale: then a
    ``.py`` file is compared in ``normal_form``, which formatting leaves alone, so ``codecgen
    check`` answers the same for the same input wherever it runs (DESIGN.md §2).
    """
    if rendered == written:
        return True
    if formatter_available() or not name.endswith(".py"):
        return False
    try:
        return normal_form(rendered) == normal_form(written)
    except (SyntaxError, ValueError, tokenize.TokenError):  # a damaged file is stale
        return False


def normal_form(source: str) -> str:
    """``source`` without its layout: the dump of its syntax tree, then its comments (which the
    tree leaves out, and which hold the ``@generated`` header), one a line."""
    tree = ast.dump(ast.parse(source))
    tokens = tokenize.generate_tokens(io.StringIO(source).readline)
    comments = [token.string.rstrip() for token in tokens if token.type == tokenize.COMMENT]
    return "\n".join([tree, *comments])


def format_modules(files: dict[str, str]) -> dict[str, str]:
    """The same files with every ``.py`` one formatted by ``ruff format`` (one ruff run)."""
    python = sorted(name for name in files if name.endswith(".py"))
    if not python or not formatter_available():
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
