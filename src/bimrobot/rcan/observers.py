"""Observers of the state manager: keep the construction graph (:mod:`bimrobot.lbd.graph`) live.

RCAN activities are finer than schedule rows (``A0001.3`` is the third RCAN activity of row
``A0001``); :class:`GraphStateObserver` maps them back: the row is ``Started`` when its first RCAN
activity starts, ``Completed`` when its last one is done and ``Failed`` when one is escalated.
Component states go to the graph as they are (the thesis' names, OnYard ... Assembled).
"""

from __future__ import annotations

from typing import Iterable

from bimrobot.rcan.activities import RcanActivity


def schedule_row_of(activity_id: str) -> str:
    """``A0001.3`` -> ``A0001`` (an id without a dot is its own row)."""
    return activity_id.rsplit(".", 1)[0]


class GraphStateObserver:
    """Forwards state changes to a ``ConstructionGraph`` (anything with ``set_component_state`` and
    ``set_activity_state`` taking the graph's state names)."""

    def __init__(self, graph, activities: Iterable[RcanActivity]):
        self.graph = graph
        self._last_of_row: dict[str, str] = {}
        for activity in activities:
            self._last_of_row[schedule_row_of(activity.activity_id)] = activity.activity_id

    def set_component_state(self, global_id: str, state: str) -> None:
        self.graph.set_component_state(global_id, state)

    def set_activity_state(self, activity_id: str, state: str) -> None:
        row = schedule_row_of(activity_id)
        if state == "started":
            self.graph.set_activity_state(row, "Started")
        elif state == "done" and self._last_of_row.get(row) == activity_id:
            self.graph.set_activity_state(row, "Completed")
        elif state == "escalated":
            self.graph.set_activity_state(row, "Failed")
