"""The order interface packages are built in: dependencies first, and no packages in a cycle.

Two packages whose types refer to each other (``a_msgs/Top`` holds a ``b_msgs/Mid`` that holds an
``a_msgs/Leaf``) can be built neither by rosidl (each package's C code needs the other's built
first) nor into codec modules (each imports the other's, a circular import): ``build_order``
refuses them naming the cycle, for ``codecgen build --from`` and ``--compile`` alike.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping, Set
from pathlib import Path

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.model import PackageDef, TypeSet

# What every service and action refers to implicitly (rosidl adds them itself).
IMPLICIT = {"srv": ("service_msgs",), "action": ("action_msgs", "service_msgs")}


def type_packages(package: PackageDef, types: TypeSet) -> set[str]:
    """Every other package whose types ``package``'s types contain, directly or through others."""
    found: set[str] = set()
    for msg in package.all_messages:
        for nested in types.closure(msg.full_name):
            found.add(nested.package)
    found.discard(package.name)
    return found


def referenced_packages(package: PackageDef, types: TypeSet) -> set[str]:
    """``type_packages`` and what services and actions refer to implicitly."""
    found = type_packages(package, types)
    if package.services or package.actions:
        found.update(IMPLICIT["srv"])
    if package.actions:
        found.update(IMPLICIT["action"])
    found.discard(package.name)
    return found


def type_reference(package: PackageDef, other: str, types: TypeSet) -> str | None:
    """How ``package`` refers to ``other`` through its types (``a_msgs/msg/Top uses
    b_msgs/msg/Mid``), or None when it does not."""
    for msg in package.all_messages:
        for nested in types.closure(msg.full_name):
            if nested.package == other:
                return f"{msg.full_name} uses {nested.full_name}"
    return None


def build_order(
    needs: Mapping[str, Set[str]],
    *,
    why: Callable[[str, str], str],
    where: Callable[[str], Path | str | None] = lambda _name: None,
) -> list[str]:
    """The packages of ``needs`` (name -> the packages it needs), each after those it needs
    among them. A cycle is a ``DefinitionError`` naming it and saying ``why`` each package needs
    the next; its path is ``where`` the first package of the cycle is."""
    order: list[str] = []
    path: list[str] = []

    def visit(name: str) -> None:
        if name in order:
            return
        if name in path:
            cycle = [*path[path.index(name) :], name]
            reasons = "; ".join(why(a, b) for a, b in itertools.pairwise(cycle))
            raise DefinitionError(
                f"packages that need each other cannot be built: {' -> '.join(cycle)} "
                f"({reasons}); move the types they share into one package",
                path=where(cycle[0]),
            )
        path.append(name)
        for dep in sorted(set(needs[name]) & set(needs)):
            visit(dep)
        path.pop()
        order.append(name)

    for name in sorted(needs):
        visit(name)
    return order
