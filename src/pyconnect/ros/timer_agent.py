"""``timer`` agents: ``response_func()`` every ``time_period`` s; ``get()`` is its last return.

An ``async def`` ``response_func`` runs on the node's coroutine loop; ticks that come while one
still runs queue behind it (pyconnect.ros.coroutines).
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

from typing import Any

from rclpy.callback_groups import CallbackGroup

from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.node_agent import NodeAgent, ResponseFunc
from pyconnect.ros.option_checks import period_problem


class TimerAgent(NodeAgent):
    """Calls ``response_func`` periodically on the node's clock."""

    conn_type = "timer"

    def __init__(
        self,
        node: AgentHost,
        *,
        conn_name: str,
        agent_name: str | None = None,
        time_period: float,
        response_func: ResponseFunc,
        callback_group: CallbackGroup | None = None,
    ) -> None:
        super().__init__(
            node,
            conn_name=conn_name,
            agent_name=agent_name,
            response_func=response_func,
            callback_group=callback_group,
        )
        problem = period_problem(time_period)
        if problem is not None:
            raise self.error(problem)
        self._handler: ResponseFunc = response_func
        self.time_period = time_period
        self.tick_count = 0
        self.timer = node.ros_node.create_timer(
            time_period, self._on_tick, callback_group=self.callback_group
        )

    def _on_tick(self) -> None:
        self.tick_count += 1
        self.call_user("response_func", self._handler, on_done=self._keep)

    def _keep(self, value: Any) -> None:
        self._latest = value

    def close(self) -> None:
        self.node.ros_node.destroy_timer(self.timer)
        super().close()
