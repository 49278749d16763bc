"""The ``codecgen`` command: build, list and check generated codec modules."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pyconnect import __version__
from pyconnect.codegen import compile_cli
from pyconnect.codegen.build import (
    DEFAULT_PACKAGES,
    default_out_dir,
    packages_in,
    render_tree,
    stale_files,
    write_tree,
)
from pyconnect.commands.common import until_reader_leaves
from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.packages import ament_prefixes, installed_packages
from pyconnect.typesys.parse import ROSIDL_INSTALL


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="codecgen", description="Generate pyconnect codec modules from ROS interfaces."
    )
    parser.add_argument("--version", action="version", version=f"codecgen {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    build = commands.add_parser("build", help="generate codec modules")
    build.add_argument("packages", nargs="*", help="installed interface packages")
    build.add_argument(
        "--from", dest="folders", action="append", default=[], type=Path,
        help="a bare folder of .msg/.srv/.action/.idl files (repeatable)",
    )  # fmt: skip
    build.add_argument(
        "--out",
        type=Path,
        default=None,
        help="output folder (default: where pyconnect loads its codecs from, generated/ of a "
        "checkout or site-packages of an installed wheel)",
    )
    compile_cli.add_compile_options(build)
    commands.add_parser("list", help="show the interface packages codecgen can see")
    check = commands.add_parser("check", help="exit 1 when generated/ is stale")
    check.add_argument(
        "--out", type=Path, default=None, help="folder to check (default: as for build)"
    )
    compile_cli.add_uninstall_command(commands)
    return parser


_INTERFACE_FOLDERS = ("msg", "srv", "action")


def _usage_error(args: argparse.Namespace) -> str | None:
    """What is wrong with the options of ``codecgen build``, or None."""
    for option, folders in (("--from", args.folders), ("--compile", args.compile_folders)):
        for folder in folders:
            if Path(folder).name in _INTERFACE_FOLDERS:  # one folder too deep
                return (
                    f"{option} {folder}: give the package folder, the one holding "
                    f"msg/, srv/ or action/ (here {Path(folder).parent})"
                )
    return compile_cli.unused_options(args)


def _build(args: argparse.Namespace) -> int:
    packages = args.packages or ([] if args.folders else list(DEFAULT_PACKAGES))
    files = render_tree(packages, args.folders)
    written = write_tree(files, args.out or default_out_dir())
    print(
        f"codecgen: {len(files)} files, {len(written)} written to {args.out or default_out_dir()}"
    )
    return 0


def _list() -> int:
    packages = installed_packages()
    for name, package in sorted(packages.items()):
        print(f"{name:32} {len(package.idl_files):4} interfaces  {package.share}")
    if not packages:
        print("codecgen: no ament index found (install ROS 2 wheels or source a ROS install)")
    else:
        print(f"{len(packages)} packages from {', '.join(str(p) for p in ament_prefixes())}")
    return 0


def _installed_by_pip(folder: Path) -> bool:
    """Whether ``folder`` lies in an environment's package folder (an installed wheel's files,
    or those of a ``codecgen build --compile`` install, which also has a RECORD)."""
    return any(part in ("site-packages", "dist-packages") for part in folder.resolve().parts)


def _check(args: argparse.Namespace) -> int:
    out = args.out or default_out_dir()
    # Check what the folder holds: the default packages (in generated/ or an empty folder) and
    # every installed package built into it; packages built from a bare folder cannot be redone.
    installed = installed_packages()
    present = packages_in(out)
    packages = [p for p in present if p in installed]
    if out.resolve() == default_out_dir().resolve() or not present:
        packages = sorted({*DEFAULT_PACKAGES, *packages})
    for skipped in sorted(set(present) - set(packages)):
        print(f"codecgen: {skipped} not checked (not installed; built with --from)")
    stale = stale_files(render_tree(packages), out)
    if stale:
        if _installed_by_pip(out):
            # `codecgen build` would overwrite files pip owns and lists in a RECORD.
            advice = "they belong to an installed package: reinstall it, do not rebuild them here"
        else:
            advice = "run `codecgen build`"
        print(f"codecgen: {len(stale)} stale files in {out} ({advice}):", file=sys.stderr)
        for relative in stale[:20]:
            print(f"  {relative}", file=sys.stderr)
        return 1
    print(f"codecgen: {out} is up to date")
    return 0


def _run(args: argparse.Namespace) -> int:
    error = _usage_error(args) if args.command == "build" else None
    if error is not None:
        print(f"codecgen: {error}", file=sys.stderr)
        return 2
    if args.command == "build" and args.compile_folders:
        return compile_cli.run_compile(args)
    if args.command == "build":
        return _build(args)
    if args.command == "uninstall":
        return compile_cli.run_uninstall(args)
    if args.command == "list":
        return _list()
    return _check(args)


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        # Inside the OSError handler: a closed pipe (`codecgen list | head`) is no error.
        return until_reader_leaves(lambda: _run(args))
    except DefinitionError as error:
        print(f"codecgen: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"codecgen: {error}", file=sys.stderr)
        return 2
    except ModuleNotFoundError as error:
        # rosidl's tools (parsers, type hashes, the --compile generators) come with ROS 2, not
        # with every install of pyconnect: a missing one is an install to complete, not a bug.
        if not (error.name or "").startswith("rosidl"):
            raise
        print(
            f"codecgen: this needs ROS 2's rosidl tools ({error}): {ROSIDL_INSTALL}",
            file=sys.stderr,
        )
        return 2


def main_entry() -> None:
    sys.exit(main())
