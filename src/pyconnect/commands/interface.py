"""``pyconnect interface list|show``: the interface types installed here, like ``ros2 interface``.

Reads the ament indexes pyconnect finds (the wheels' ``share/``, ``AMENT_PREFIX_PATH``, and the
prefixes of packages built with ``codecgen build --compile``); no ROS graph, no rclpy needed.
``show`` prints a type's .msg/.srv/.action text with every nested message type expanded below
its field, indented by a tab, as ``ros2 interface show`` does. A type defined in an ``.idl``
file (no .msg/.srv/.action) is shown as that file's text, and is not expanded below a field.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

from pyconnect.commands.common import Parser, UsageError
from pyconnect.typesys.packages import InstalledPackage, installed_packages
from pyconnect.typesys.primitives import MSG_BUILTIN_NAMES

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands

__all__ = ["interface_text", "register"]

_KINDS = (("msg", "Messages"), ("srv", "Services"), ("action", "Actions"))

EXAMPLES = """examples:
  pyconnect interface list
  pyconnect interface list std_msgs sensor_msgs
  pyconnect interface list --packages
  pyconnect interface show geometry_msgs/msg/Twist
  pyconnect interface show std_srvs/srv/SetBool --raw
"""


def register(commands: Subcommands) -> Subcommands:
    """Add ``interface list`` and ``interface show`` to the ``pyconnect`` subparsers."""
    interface = commands.add_parser(
        "interface", help="list and show installed interface types", epilog=EXAMPLES
    )
    actions = interface.add_subparsers(dest="action", required=True, parser_class=Parser)
    listing = actions.add_parser(
        "list", help="the interface types pyconnect can see", epilog=EXAMPLES
    )
    listing.add_argument("packages", nargs="*", help="only these packages")
    listing.add_argument("--packages", dest="only_packages", action="store_true",
                         help="list package names only")  # fmt: skip
    listing.set_defaults(run=_list)
    show = actions.add_parser("show", help="print a type's definition", epilog=EXAMPLES)
    show.add_argument("type", help="pkg/msg/Name, pkg/srv/Name, pkg/action/Name or pkg/Name")
    show.add_argument("--raw", action="store_true", help="do not expand nested types")
    show.set_defaults(run=_show)
    return actions


def _types(package: InstalledPackage) -> dict[str, list[str]]:
    """``{"msg": [...], "srv": [...], "action": [...]}`` full names of a package's types."""
    found: dict[str, list[str]] = {kind: [] for kind, _ in _KINDS}
    for relative in package.idl_files:
        namespace, _, filename = relative.partition("/")
        if namespace in found:
            found[namespace].append(f"{package.name}/{namespace}/{Path(filename).stem}")
    return found


def _list(args: argparse.Namespace, out: TextIO, _err: TextIO) -> int:
    packages = installed_packages()
    unknown = sorted(set(args.packages) - set(packages))
    if unknown:
        raise UsageError(
            f"package {unknown[0]!r} is not installed (see `pyconnect interface list`)"
        )
    chosen = [packages[name] for name in sorted(args.packages or packages)]
    if args.only_packages:
        for package in chosen:
            print(f"{package.name}  ({package.share.parent.parent})", file=out)
        return 0
    types = [_types(package) for package in chosen]
    for kind, title in _KINDS:
        print(f"{title}:", file=out)
        for found in types:
            for name in found[kind]:
                print(f"    {name}", file=out)
    return 0


def _definition_file(full_name: str) -> Path:
    """The .msg/.srv/.action file of an installed type, else its .idl file."""
    package, namespace, name = full_name.split("/")
    installed = installed_packages().get(package)
    if installed is None:
        raise UsageError(f"{full_name}: package {package!r} is not installed")
    path = installed.share / namespace / f"{name}.{namespace}"
    idl = path.with_suffix(".idl")
    if not path.is_file() and idl.is_file():
        return idl
    if not path.is_file():
        raise UsageError(
            f"{full_name}: no such type ({path.name} is not in {installed.share}, nor {idl.name})"
        )
    return path


def _resolve(type_name: str) -> str:
    parts = type_name.strip().strip("/").split("/")
    if len(parts) == 3 and parts[1] in ("msg", "srv", "action"):
        return "/".join(parts)
    if len(parts) == 2:
        installed = installed_packages().get(parts[0])
        if installed is not None:
            for namespace in ("msg", "srv", "action"):
                base = installed.share / namespace / parts[1]
                if (
                    base.with_suffix(f".{namespace}").is_file()
                    or base.with_suffix(".idl").is_file()
                ):
                    return f"{parts[0]}/{namespace}/{parts[1]}"
        return f"{parts[0]}/msg/{parts[1]}"
    raise UsageError(f"{type_name!r} is not a type name (pkg/msg/Name, pkg/srv/Name or pkg/Name)")


def _nested_type(line: str, package: str) -> str | None:
    """``pkg/msg/Name`` of the message type a field line declares, None for anything else."""
    code = line.split("#", 1)[0].strip()
    tokens = code.split(None, 2)
    if len(tokens) < 2 or code == "---" or "=" in tokens[1]:
        return None
    if len(tokens) > 2 and tokens[2].lstrip().startswith("="):
        return None  # a constant
    base = tokens[0].split("[", 1)[0].split("<=", 1)[0]
    if base in MSG_BUILTIN_NAMES:
        return None
    parts = base.split("/")
    if len(parts) == 1:
        return f"{package}/msg/{base}"
    return f"{parts[0]}/msg/{parts[-1]}"


def interface_text(type_name: str, *, expand: bool = True) -> str:
    """The definition of an installed type, nested message types expanded below their fields."""
    full_name = _resolve(type_name)
    path = _definition_file(full_name)
    text = path.read_text(encoding="utf-8")
    if not expand or path.suffix == ".idl":
        return text
    lines: list[str] = []

    def emit(definition: str, package: str, depth: int) -> None:
        for line in definition.splitlines():
            if depth and (not line.strip() or line.lstrip().startswith("#")):
                continue  # nested definitions are shown without their comments
            lines.append("\t" * depth + line.rstrip())
            nested = _nested_type(line, package)
            if nested is not None:
                nested_path = _definition_file(nested)
                if nested_path.suffix != ".idl":  # IDL text does not indent into a .msg
                    emit(nested_path.read_text(encoding="utf-8"), nested.split("/")[0], depth + 1)

    emit(text, full_name.split("/")[0], 0)
    return "\n".join(lines) + "\n"


def _show(args: argparse.Namespace, out: TextIO, _err: TextIO) -> int:
    out.write(interface_text(args.type, expand=not args.raw))
    return 0
