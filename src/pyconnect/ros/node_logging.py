"""Logging and recording of a ``CustomNode``: log folders per agent, ``start_log_subs``, MCAP.

A mixin of ``CustomNode`` (pyconnect.ros.custom_node): the node keeps its agents, lock and
name; this part lays out ``<log_dir>/<node>/<session>/<agent>/`` folders, logs the latest value
of every sub at a fixed rate, and records raw messages of the subscribed topics.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import datetime
import math
import numbers
import threading
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from pyconnect.errors import PyconnectError
from pyconnect.record.log_dirs import (
    default_log_root,
    distinct_path_components,
    safe_path_component,
)
from pyconnect.ros.node_agent import NodeAgent
from pyconnect.ros.recording import Recording
from pyconnect.ros.subscriber_agent import SubscriberAgent

MAX_TIMER_SECONDS = (2**63 - 1) / 1e9
"""The longest period an rcl timer holds (int64 nanoseconds): rclpy refuses longer ones with a
bare TypeError naming nothing."""


def _fps_problem(fps: object) -> bool:
    """Whether ``fps`` cannot be a logging rate (NaN passed ``<= 0``; inf made a 0 s timer
    that ran flat out)."""
    if isinstance(fps, bool) or not isinstance(fps, numbers.Real):
        return True
    rate = float(fps)
    return not (math.isfinite(rate) and rate > 0 and 1.0 / rate <= MAX_TIMER_SECONDS)


class NodeLogging:
    """Log folders, periodic sub logging and recording for ``CustomNode``."""

    # Set up by CustomNode.__init__.
    name: str
    agents: dict[str, NodeAgent]
    _lock: threading.RLock
    _log_root: Path | None
    _log_session: datetime.datetime | None
    _log_session_dir: Path | None
    _log_subs_timer: Any
    _log_subs_recording: Recording | None
    _recordings: list[Recording]
    _log_dirs: dict[str, Path]

    if TYPE_CHECKING:  # rclpy's Node methods, on CustomNode (a stub here would shadow them)

        def create_timer(
            self,
            timer_period_sec: float,
            callback: Any,
            *,
            callback_group: Any = None,
            clock: Clock | None = None,
        ) -> Any: ...

        def destroy_timer(self, timer: Any) -> bool: ...

        def get_fully_qualified_name(self) -> str: ...

        def _refuse_when_closed(self, what: str) -> None: ...

    def agent_log_dir(self, agent_name: str) -> Path:
        """``<log_dir>/<node>/<session>/<agent>/``, created once; agents whose names clean to
        the same folder name (``status`` and ``/status``) get distinct folders."""
        with self._lock:
            directory = self._log_dirs.get(agent_name)
            if directory is not None:
                return directory
            if self._log_session is None:
                self._log_session = datetime.datetime.now()
            if self._log_session_dir is None:
                # The fully qualified name: nodes of one name in two namespaces (two robots'
                # drivers) must not share a folder. ``/driver`` stays ``driver``.
                node_dir = self.log_dir / safe_path_component(self.get_fully_qualified_name())
                self._log_session_dir = _claim_session_dir(
                    node_dir, self._log_session.strftime("%Y%m%d-%H%M%S")
                )
            session = self._log_session_dir
            taken = [path.name for path in self._log_dirs.values()]
            directory = session / distinct_path_components([agent_name], taken)[agent_name]
            directory.mkdir(parents=True, exist_ok=True)
            self._log_dirs[agent_name] = directory
            return directory

    @property
    def log_dir(self) -> Path:
        """The root under which ``<node>/<session>/<agent>/`` log directories are made:
        ``log_dir=``, else ``$PYCONNECT_LOG_DIR`` or ``./pyconnect_logs`` as they are when first
        needed (a program may set them after importing pyconnect), kept from then on."""
        if self._log_root is None:
            self._log_root = default_log_root()
        return self._log_root

    def make_log_dirs(self) -> dict[str, Path]:
        """Create this session's log directory of every agent; {agent name: directory}."""
        return {name: agent.make_log_dirs() for name, agent in list(self.agents.items())}

    @property
    def is_logging_subs(self) -> bool:
        return self._log_subs_timer is not None

    def start_log_subs(self, fps: float = 10, record: str | Path | None = None) -> None:
        """Log the latest value of every sub ``fps`` times a second (new values only).

        Subs with ``do_log_msg=True`` already log every value and are left out (one writer per
        value). ``record=path`` also records the raw messages of the subscribed topics to MCAP.
        """
        if _fps_problem(fps):
            raise PyconnectError(
                f"start_log_subs: fps must be a finite number > 0 whose period fits a ROS timer "
                f"(at most {MAX_TIMER_SECONDS:.3g} s), got {fps!r}"
            )
        with self._lock:
            self._refuse_when_closed("start logging its subs")
            if self._log_subs_timer is not None:
                raise PyconnectError(
                    f"node {self.get_fully_qualified_name()!r} already logs its subs"
                )
            seen: dict[str, int] = {}

            def log_latest() -> None:
                for agent in list(self.agents.values()):
                    if not isinstance(agent, SubscriberAgent) or agent.do_log_msg:
                        continue
                    count = agent.message_count
                    if count == 0 or seen.get(agent.name) == count:
                        continue
                    seen[agent.name] = count
                    try:
                        agent.log_msg(agent.get())
                    except Exception as error:
                        agent.report_exception("start_log_subs", error)

            self._log_subs_recording = self.record(record) if record is not None else None
            # Wall time, as the rate is about the disk: under use_sim_time a ROS-time timer
            # would log nothing while /clock is absent or paused.
            self._log_subs_timer = self.create_timer(
                1.0 / fps,
                log_latest,
                callback_group=MutuallyExclusiveCallbackGroup(),
                clock=Clock(clock_type=ClockType.STEADY_TIME),
            )

    def stop_log_subs(self, timeout: float | None = 10.0) -> None:
        """Stop ``start_log_subs`` and flush what it logged."""
        with self._lock:
            timer, self._log_subs_timer = self._log_subs_timer, None
            recording, self._log_subs_recording = self._log_subs_recording, None
        if timer is not None:
            self.destroy_timer(timer)
        if recording is not None:
            recording.stop()
        for agent in list(self.agents.values()):
            agent.flush_log(timeout)

    def record(self, path: str | Path, topics: Iterable[str] | None = None) -> Recording:
        """Record raw messages of ``topics`` (default: every sub's topic) to an MCAP file."""
        with self._lock:
            # Checked before the file is made; the lock keeps shutdown from destroying the node
            # while the recording subscribes (shutdown stops every recording in the list).
            self._refuse_when_closed(f"record to {str(path)!r}")
            recording = Recording(
                cast(Node, self), self.agents, Path(path), None if topics is None else list(topics)
            )
            # Stopped ones are let go here (shutdown stops the rest): one recording per
            # episode kept every finished one, with its file state, for the node's life.
            self._recordings[:] = [known for known in self._recordings if not known.stopped]
            self._recordings.append(recording)
        return recording


def _claim_session_dir(node_dir: Path, stamp: str) -> Path:
    """A session folder no other node process uses: ``<stamp>``, else ``<stamp>_2``, ...

    A node started twice within one second (a respawn, two launches) would otherwise write its
    files into the other's folder, where file names (sequence and stamp) may collide. ``mkdir``
    without ``exist_ok`` claims a folder atomically across processes.
    """
    node_dir.mkdir(parents=True, exist_ok=True)
    name, suffix = stamp, 1
    while True:
        try:
            (node_dir / name).mkdir()
        except FileExistsError:
            suffix += 1
            name = f"{stamp}_{suffix}"
            continue
        return node_dir / name
