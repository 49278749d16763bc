"""``codecgen`` options for compiled interface packages: ``build --compile``, ``uninstall``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_compile_options(build: argparse.ArgumentParser) -> None:
    """``--compile DIR`` (repeatable), ``--prefix`` and ``--force`` on ``codecgen build``."""
    build.add_argument(
        "--compile", dest="compile_folders", action="append", default=[], type=Path,
        metavar="DIR", help="build an importable interface package from a folder of "
        ".msg/.srv/.action/.idl files, as colcon would (repeatable; dependencies first)",
    )  # fmt: skip
    build.add_argument(
        "--prefix", type=Path, default=None,
        help="install prefix for --compile (default: the active environment)",
    )  # fmt: skip
    build.add_argument("--force", action="store_true", help="rebuild even when up to date")


def unused_options(args: argparse.Namespace) -> str | None:
    """Why the options of ``codecgen build`` do not go together, or None when they do.

    ``--compile`` installs into a prefix; ``--out``, ``--from`` and package names write codecs
    into a folder: each set means nothing to the other, so a mix is refused, not half done.
    """
    if args.compile_folders:
        given = [f"--out {args.out}"] if args.out is not None else []
        given += [f"--from {folder}" for folder in args.folders]
        given += list(args.packages)
        if given:
            return (
                f"--compile does not take --out, --from or package names (given: "
                f"{', '.join(map(str, given))}): run those as a codecgen build of their own"
            )
        return None
    given = [f"--prefix {args.prefix}"] if args.prefix is not None else []
    given += ["--force"] if args.force else []
    if given:
        return f"{' and '.join(given)} only go with --compile DIR"
    return None


def add_uninstall_command(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    uninstall = commands.add_parser("uninstall", help="remove a package built with --compile")
    uninstall.add_argument("packages", nargs="+")
    uninstall.add_argument("--prefix", type=Path, default=None)


def run_compile(args: argparse.Namespace) -> int:
    from pyconnect.codegen.compile_dependents import stale_dependents
    from pyconnect.codegen.compile_package import compile_folders

    results = compile_folders(args.compile_folders, prefix=args.prefix, force=args.force)
    for result in results:
        where = result.layout.python / result.package
        print(f"codecgen: {result.package}: {result.status} ({where})")
    changed = [r.package for r in results if r.changed_types]
    if changed:
        layout = results[0].layout
        for dependent in stale_dependents(layout, changed, {r.package for r in results}):
            print(f"codecgen: warning: {dependent.advice(layout)}", file=sys.stderr)
    return 0


def run_uninstall(args: argparse.Namespace) -> int:
    from pyconnect.codegen.compile_install import InstallLayout, uninstall

    layout = InstallLayout.for_prefix(args.prefix)
    status = 0
    for package in args.packages:
        removed = uninstall(layout, package)
        if removed:
            print(f"codecgen: {package}: removed {len(removed)} files from {layout.prefix}")
        else:
            print(
                f"codecgen: {package}: no package built by codecgen in {layout.prefix}",
                file=sys.stderr,
            )
            status = 1
    return status
