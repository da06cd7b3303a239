"""Plans from schedules: weights are the model's (or unknown, never 0 kg), an assembly is lifted as one
unit, and a robot that works on a component in place is not limited by that component's weight."""

from __future__ import annotations

from pathlib import Path

import pytest

from bimrobot.core.errors import InputError
from bimrobot.core.tasks import Activity
from bimrobot.schedule.schedule import Schedule
from bimrobot.rcan.activities import ActivityKind as K
from bimrobot.rcan.generation import TaskAllocator, parse_capabilities
from bimrobot.rcan.plans import plan_from_schedule, unknown_weight_components


def light_table(table_5_2):
    """One mobile manipulator that carries 500 kg."""
    return parse_capabilities({"robot_types": table_5_2, "robots": {"arm": {
        "types": ["mobile_base", "manipulator", "gripper"], "payload_kg": 500, "reach_m": 3}}}, "light table")


def test_without_a_model_weights_are_unknown_not_zero(table_5_2):
    rows = [Activity("A1", "Transport C", "transport", "COL", None, 0, 10, target=(0.0, 0.0, 0.0))]
    plan = plan_from_schedule(Schedule(rows))
    assert {a.weight_kg for a in plan} == {None}
    assert unknown_weight_components(plan) == ["COL"]
    assert TaskAllocator(light_table(table_5_2)).choose(plan[0]) == "arm"  # unknown: not checked, and reported


def test_work_on_a_component_in_place_needs_no_payload_for_it(table_5_2):
    """A joint fixed on a heavy prebuilt slab: the robot lifts the light beam, not the slab."""

    class Model:  # the two members of a BuildingModel the plan reads
        source = Path("test.ifc")
        assemblies: dict = {}

        class _Element:
            def __init__(self, kg, gid):
                import numpy as np

                self.weight_kg, self.global_id = kg, gid
                self.vertices = np.array([[0, 0, 0], [0.3, 0.3, 6.0]], dtype=float)
                self.placement = np.eye(4)

            @property
            def local_bounds(self):
                return self.vertices

            @property
            def position(self):
                return self.placement[:3, 3]

        elements = {"BEAM": _Element(300.0, "BEAM"), "SLAB": _Element(60000.0, "SLAB")}

    rows = [
        Activity("A1", "Transport BEAM", "transport", "BEAM", None, 0, 10, target=(1.0, 0.0, 3.0)),
        Activity("A2", "Assemble BEAM", "assemble", "BEAM", None, 10, 20, ("A1",), target=(1.0, 0.0, 3.0)),
        Activity("A3", "Assemble SLAB:BEAM", "assemble", "SLAB", None, 20, 30, ("A2",), target=(0.0, 0.0, 0.0)),
    ]
    plan = plan_from_schedule(Schedule(rows), Model())
    slab = [a for a in plan if a.component_id == "SLAB"]
    assert [a.kind for a in slab] == [K.MOVE_TO_COMPONENT, K.POSITION_FOR_INSTALLING, K.INSTALL]
    assert all(not a.lifts and a.weight_kg == 60000.0 for a in slab)  # its weight stays known, but nobody lifts it
    assert all(a.lifts for a in plan if a.component_id == "BEAM")
    allocator = TaskAllocator(light_table(table_5_2))
    assert allocator.choose(slab[0]) == "arm"
    heavy_lift = next(a for a in plan if a.kind is K.PICK_UP).__class__(
        "X.1", "SLAB", K.PICK_UP, slab[0].target, 60000.0)
    with pytest.raises(InputError, match=r"no robot can take 'Pick up' of component SLAB \(activity X.1, 60000.0 kg\)"):
        allocator.choose(heavy_lift)


def test_an_assembly_is_planned_as_one_unit_with_the_weight_of_its_parts(shared_ifc):
    from bimrobot.bim import load_model
    from bimrobot.bim.unknown_weight import UnknownWeightRule, apply_unknown_weight_rule

    model = load_model(shared_ifc("MULTICOM-trappen_bordessen.ifc"))
    apply_unknown_weight_rule(model.elements.values(), UnknownWeightRule(), "trappen")
    unit, assembly = max(model.assemblies.items(), key=lambda item: len(item[1].part_ids))
    rows = [Activity("A1", "Transport unit", "transport", unit, None, 0, 10),  # no target: from the model
            Activity("A2", "Position unit", "position", unit, None, 10, 20, ("A1",))]
    plan = plan_from_schedule(Schedule(rows), model)
    parts = [model.elements[p] for p in assembly.part_ids]
    assert plan[0].weight_kg == pytest.approx(sum(e.weight_kg for e in parts))
    # no assemble row fixes the unit: its positioning installs it (Assembled, as the simulation counts it)
    assert [a.kind for a in plan[-2:]] == [K.POSITION_FOR_INSTALLING, K.INSTALL]
    # an assembly goes where the simulated unit goes: its main part's origin (the schedule's target)
    from bimrobot.sco.build import main_part

    assert [plan[-1].target.x, plan[-1].target.y, plan[-1].target.z] == pytest.approx(main_part(parts).position)
    assert min(plan[0].section_m) > 0


def test_a_second_node_of_a_component_waits_until_the_first_put_it_in_place():
    """Per-node schedules: a beam's two position rows both wait for its transport, not for each other.
    The first picks the beam up at its drop-off and installs it; the second works on it in place, so it
    must wait for that install (else a robot 'positions' a beam still lying at its drop-off)."""
    target = (1.0, 0.0, 3.0)
    rows = [
        Activity("A1", "Transport BEAM", "transport", "BEAM", None, 0, 10, target=target),
        Activity("A2", "Position BEAM node 1", "position", "BEAM", None, 10, 20, ("A1",), target=target),
        Activity("A3", "Position BEAM node 2", "position", "BEAM", None, 10, 20, ("A1",), target=target),
        Activity("A4", "Assemble BEAM node 1", "assemble", "BEAM", None, 20, 30, ("A2",), target=target),
    ]
    plan = {a.activity_id: a for a in plan_from_schedule(Schedule(rows))}
    first = [a for a in plan if a.startswith("A2.")]
    assert plan["A2.1"].kind is K.MOVE_TO_COMPONENT and plan["A2.3"].kind is K.PICK_UP  # from the drop-off
    assert set(plan["A3.1"].predecessors) == {"A1.4", first[-1]}  # the second node waits for the first
    assert "A3.3" not in plan or plan["A3.3"].kind is not K.PICK_UP  # and works on the beam in place
    assert plan["A4.1"].predecessors[0] == first[-1]  # the schedule's own predecessor comes first
