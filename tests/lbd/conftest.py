"""Fixtures for the lbd tests: the chapter-4 steel frame (tests/conftest.py) and a schedule for it in
the format `bimrobot simulate` writes (docs/conventions.md)."""

from __future__ import annotations

import pytest

from shared_data import SHARED_ONTOLOGIES

from bimrobot.schedule.csv import ACTIVITY_TASK_TYPES, write_schedule_csv
from bimrobot.core.tasks import Activity
from bimrobot.schedule.schedule import Schedule


@pytest.fixture(scope="session")
def frame_model(steel_frame_model):
    return steel_frame_model


def frame_schedule(model) -> Schedule:
    """Columns then beams, each transported, positioned and assembled on every connection node it
    relates; one robot per activity kind, so each robot works through its activities in turn."""
    robots = {"transport": "Transport 1", "position": "Positioning 1", "assemble": "Assembly 1"}
    seconds = {"transport": 100.0, "position": 120.0, "assemble": 60.0}
    free = dict.fromkeys(robots, 0.0)
    activities: list[Activity] = []
    for element in model.by_class("IfcColumn") + model.by_class("IfcBeam"):
        previous: Activity | None = None
        nodes = [f"{c.relating_id}:{c.related_id}" for c in model.connections if c.related_id == element.global_id]
        steps = [("transport", None), ("position", None)] + [("assemble", node) for node in nodes]
        for kind, node in steps:
            start = max(free[kind], previous.finish if previous else 0.0)
            activity = Activity(
                id=f"A{len(activities) + 1:04d}",
                name=f"{kind.capitalize()} {node or element.global_id}",
                activity=kind,
                global_id=element.global_id,
                robot=robots[kind],
                start=start,
                finish=start + seconds[kind],
                predecessors=(previous.id,) if previous else (),
                target=tuple(float(v) for v in element.position),
                storey=element.storey_id,
                predefined_type=ACTIVITY_TASK_TYPES[kind],
                node_id=node,
            )
            free[kind] = activity.finish
            activities.append(activity)
            previous = activity
    return Schedule(activities)


@pytest.fixture(scope="session")
def frame_schedule_csv(frame_model, tmp_path_factory):
    return write_schedule_csv(frame_schedule(frame_model), tmp_path_factory.mktemp("lbd") / "schedule.csv")


@pytest.fixture
def ontology_file():
    """A function: ontology_file("bot.ttl") -> Path under ../shared/data/ontologies (skips when absent)."""
    def find(name: str):
        path = SHARED_ONTOLOGIES / name
        if not path.exists():
            pytest.skip(f"{path} is absent: the shared ontologies live beside the repository, not in it")
        return path

    return find
