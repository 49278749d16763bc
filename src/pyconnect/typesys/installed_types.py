"""Whether an interface type is installed, and the installed names close to a misspelt one."""

from __future__ import annotations

from pyconnect.errors import CodecNotFoundError
from pyconnect.typesys.names import split_part

__all__ = ["close_names_hint", "type_installed"]


def type_installed(full_name: str) -> bool:
    """Whether ``pkg/ns/Name`` is installed: its interface file, or its Python class."""
    from pyconnect.typesys.classes import import_class
    from pyconnect.typesys.packages import installed_share_dirs

    package, namespace, name = full_name.split("/")
    part = split_part(namespace, name)
    interface = part[0] if part is not None else name
    share = installed_share_dirs().get(package)
    if share is not None and (part is not None or namespace == "msg"):
        # A service's or action's parts live in its own file: SetBool_Request in SetBool.srv.
        for suffix in (".idl", f".{namespace}"):
            if (share / namespace / f"{interface}{suffix}").is_file():
                return True
    try:  # a package with Python classes but no ament index entry
        import_class(full_name)
    except CodecNotFoundError:
        return False
    return True


def close_names_hint(full_name: str) -> str:
    """The hint "; did you mean pkg/ns/Name?" when an installed name is close, else ""."""
    import difflib

    from pyconnect.typesys.packages import installed_share_dirs

    package, namespace, name = full_name.split("/")
    share = installed_share_dirs().get(package)
    if share is None or not (share / namespace).is_dir():
        return ""
    names = {path.stem for path in (share / namespace).iterdir()}
    close = difflib.get_close_matches(name, sorted(names), n=1)
    return f"; did you mean {package}/{namespace}/{close[0]}?" if close else ""
