"""RIHS01 type hashes, computed as rosidl's build does (rosidl_generator_type_description)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from pyconnect.typesys.errors import DefinitionError


def rihs01_hashes(elements: Iterable[Any]) -> dict[str, str]:
    """RIHS01 hashes of every type in ``elements``, computed as rosidl's build computes them."""
    import rosidl_generator_type_description as td
    from rosidl_parser import definition as d

    individual: dict[str, Any] = {}
    for element in elements:
        if isinstance(element, d.Message):
            td.add_msg(element, individual)
        elif isinstance(element, d.Service):
            td.add_srv(element, individual)
        elif isinstance(element, d.Action):
            td.add_action(element, individual)
    serialized = {
        name: td.serialize_individual_type_description(t.namespaced_type, t.members)
        for name, t in individual.items()
    }
    hashes: dict[str, str] = {}
    for name in individual:
        try:
            full = td.extract_full_type_description(name, serialized)
        except KeyError as missing:
            raise DefinitionError(f"{name}: unknown type {missing.args[0]}") from None
        hashes[name] = td.calculate_type_hash(full)
    return hashes
