"""The context nodes share: its ROS arguments are those of the first node; a later args= differing
from them is refused, not ignored."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import rclpy

from pyconnect.errors import PyconnectError
from pyconnect.ros.custom_node import CustomNode

FIRST_ARGS = ["prog", "--ros-args", "-p", "a:=5", "-r", "chatter:=t1"]


@pytest.fixture
def first(tmp_path: Path) -> Iterator[CustomNode]:
    """The first node on a fresh context: it initialises the context with ``FIRST_ARGS``."""
    node = CustomNode(
        "first", context=rclpy.Context(), args=FIRST_ARGS, handle_signals=False, log_dir=tmp_path
    )
    yield node
    node.shutdown()


def _second(first: CustomNode, tmp_path: Path, **options: Any) -> CustomNode:
    return CustomNode(
        "second", context=first.context, handle_signals=False, log_dir=tmp_path, **options
    )


def test_other_args_for_a_later_node_are_refused(first: CustomNode, tmp_path: Path) -> None:
    with pytest.raises(PyconnectError) as caught:
        _second(first, tmp_path, args=["prog", "--ros-args", "-p", "a:=7"])
    assert str(caught.value) == (
        "args=: the process's ROS arguments are set once, by the first node (per context): "
        "expected ['--ros-args', '-p', 'a:=5', '-r', 'chatter:=t1'] as that node gave them "
        "(or no args=), got ['--ros-args', '-p', 'a:=7']; give this node arguments of its own "
        "with cli_args=['--ros-args', ...]"
    )
    assert first.get_param("a") == 5  # the first node and its context are untouched
    assert first.context.ok()


def test_the_same_args_no_args_or_cli_args_are_accepted(
    first: CustomNode, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sys, "argv", ["prog", "--ros-args", "-p", "a:=8"])  # not asked for
    # Only ROS arguments count: the program name and its own arguments may differ.
    same = _second(first, tmp_path, args=["other", "--flag", *FIRST_ARGS[1:], "--", "x"])
    unset = CustomNode("unset", context=first.context, handle_signals=False, log_dir=tmp_path)
    own = CustomNode(
        "own", context=first.context, handle_signals=False, log_dir=tmp_path,
        cli_args=["--ros-args", "-p", "b:=2"],
    )  # fmt: skip
    try:
        assert [node.get_param("a") for node in (same, unset, own)] == [5, 5, 5]
        assert own.get_param("b") == 2
    finally:
        for node in (same, unset, own):
            node.shutdown()
    assert first.context.ok()


def test_the_next_default_context_takes_new_args(tmp_path: Path) -> None:
    one = CustomNode("one", args=FIRST_ARGS, handle_signals=False, log_dir=tmp_path)
    # The last node on the default context pyconnect initialised: it is shut down and rclpy
    # makes a fresh one, which the next node initialises with its own args.
    one.shutdown()
    two = CustomNode(
        "two", args=["prog", "--ros-args", "-p", "a:=9"], handle_signals=False, log_dir=tmp_path
    )
    try:
        assert two.get_param("a") == 9
    finally:
        two.shutdown()
