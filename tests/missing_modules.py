"""Tests' stand-in for an install that lacks some packages: importing them fails as it would."""

from __future__ import annotations

import importlib.abc
import sys
from collections.abc import Sequence
from types import ModuleType

import pytest


class _Refuse(importlib.abc.MetaPathFinder):
    """Finds none of ``packages``' modules, with the error an absent package gives."""

    def __init__(self, packages: tuple[str, ...]) -> None:
        self.packages = packages

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> None:
        if fullname.split(".", maxsplit=1)[0] in self.packages:
            raise ModuleNotFoundError(f"No module named {fullname!r}", name=fullname)


def without(monkeypatch: pytest.MonkeyPatch, *packages: str) -> None:
    """Until the test ends, ``import`` of ``packages`` (or their modules) fails as if they were
    not installed, whether or not they were imported before: the message is always the same."""
    for name in list(sys.modules):
        if name.split(".")[0] in packages:
            monkeypatch.delitem(sys.modules, name)
    monkeypatch.setattr(sys, "meta_path", [_Refuse(packages), *sys.meta_path])
