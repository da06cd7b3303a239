"""The planning instance (`bimrobot plan export`) is the problem `simulate --per-joint` runs."""

import json

import numpy as np
import pytest

from bimrobot.bim.examples import steel_frame
from bimrobot.bim.selection import DEFAULT_PREBUILT
from bimrobot.cli import main
from bimrobot.coordination.inputs import load_building
from bimrobot.site.fleet import load_fleet
from bimrobot.coordination.simulation import simulate
from bimrobot.core.errors import InputError
from bimrobot.planning.problem import build_instance, dumps, load_instance
from bimrobot.sco import build_smart_model
from bimrobot.site.site import site_for


@pytest.fixture(scope="module")
def frame(tmp_path_factory):
    """The thesis' steel frame, read as `simulate` reads it, with fleet2 on its site."""
    path = steel_frame(tmp_path_factory.mktemp("frame") / "frame.ifc")
    model, elevations = load_building(str(path))
    site = site_for(None, model.elements.values())
    smart = build_smart_model(model, prebuilt_classes=DEFAULT_PREBUILT)
    return path, smart, load_fleet("fleet2"), site, elevations


def _task_of(row, smart) -> str:
    """The instance task a schedule row belongs to (a joint's assembly is written one row per node)."""
    kind, subject = str(row.activity), row.name.split(" ", 1)[1]
    return f"assemble:{smart.nodes[subject].joint_id}" if kind == "assemble" else f"{kind}:{subject}"


def _predecessors(instance) -> dict[str, dict[str, str]]:
    """task -> {task that must finish before it: rule}, the floor gates opened up into the joints they wait for."""
    direct: dict[str, dict[str, str]] = {}
    for edge in instance["precedences"]:
        direct.setdefault(edge["after"], {})[edge["before"]] = edge["rule"]
    gates = {g["id"] for g in instance["gates"]}

    def tasks_before(key):
        found = {}
        for p, rule in direct.get(key, {}).items():
            found.update({q: "floor_gate" for q in tasks_before(p)} if p in gates else {p: rule})
        return found

    return {t["id"]: tasks_before(t["id"]) for t in instance["tasks"]}


def test_one_gate_per_floor_says_what_every_lower_joint_said(frame):
    """Version 2: the frame's transports of floor 2 wait for the one gate of floor 1, which waits for every
    joint assembly of floor 1: the same order as task_graph's full list, in far fewer edges."""
    from bimrobot.planning.optimal_graph import task_graph
    from bimrobot.coordination.simulation import ConstructionSimulation

    _, smart, fleet, site, elevations = frame
    instance = build_instance(smart, fleet, site, elevations)
    assert instance["gates"] == [{"id": "gate:0", "floor": 0}]
    sim = ConstructionSimulation(smart, fleet, site, storey_elevations=elevations)
    tasks = {t["id"] for t in instance["tasks"]}
    full = {t.key: {p for p in t.predecessors if p in tasks} for t in task_graph(sim.smart, sim)}
    assert {key: set(found) for key, found in _predecessors(instance).items()} == full
    gate_edges = [e for e in instance["precedences"] if e["rule"] == "floor_gate"]
    upper = sum(1 for t in instance["tasks"] if t["kind"] == "transport" and t["floor"] == 1)
    lower = sum(1 for t in instance["tasks"] if t["kind"] == "assemble" and t["floor"] == 0)
    assert len(gate_edges) == upper + lower  # not upper x lower


def test_the_floor_gate_waits_for_a_part_without_connection_nodes(freestanding_frame):
    """Version 3: a ground-floor column that touches nothing closes its floor when it is positioned, in the
    simulation (every transport of the floor above starts after that) and so in the instance (its
    positioning is before gate:0, which every upper transport waits for)."""
    problem = freestanding_frame
    instance = build_instance(problem.smart, problem.fleet, problem.site, problem.storey_elevations)
    assert {"before": "position:column-free", "after": "gate:0", "rule": "floor_gate"} in instance["precedences"]
    upper = [t["id"] for t in instance["tasks"] if t["kind"] == "transport" and t["floor"] == 1]
    before = _predecessors(instance)
    assert upper and all(before[key].get("position:column-free") == "floor_gate" for key in upper)
    result = simulate(problem.smart, problem.fleet, problem.site, storey_elevations=problem.storey_elevations, per_node=False)
    positioned = next(a.finish for a in result.activities if a.activity == "position" and a.global_id == "column-free")
    upper_starts = [a.start for a in result.activities if f"{a.activity}:{a.global_id}" in upper]
    assert len(upper_starts) == len(upper) and min(upper_starts) >= positioned


def test_the_instance_is_the_problem_simulate_runs(frame):
    """Same tasks, same precedences, and every task takes, on the robot simulate chose, the travel from
    where that robot was plus the instance's handling time: the row's duration."""
    _, smart, fleet, site, elevations = frame
    instance = build_instance(smart, fleet, site, elevations)
    result = simulate(smart, fleet, site, storey_elevations=elevations, per_node=False)
    task_of = {row.id: _task_of(row, smart) for row in result.activities}
    rows: dict[str, list] = {}
    for row in result.activities:
        rows.setdefault(task_of[row.id], []).append(row)
    tasks = {t["id"]: t for t in instance["tasks"]}
    assert sorted(tasks) == sorted(rows)
    assert len(tasks) == 28

    before = _predecessors(instance)
    for key, group in rows.items():
        scheduled = {task_of[p] for row in group for p in row.predecessors} - {key}
        assert scheduled <= set(before[key])  # the floor gate: the row that closed the floor, one of the joints below
        assert {p for p, rule in before[key].items() if rule != "floor_gate"} == {p for p in scheduled if not p.startswith("assemble:") or not key.startswith("transport:")}

    robots = {r["name"]: r for r in instance["robots"]}
    where = {name: np.array(r["home_site_m"]) for name, r in robots.items()}
    for key, group in sorted(rows.items(), key=lambda item: min(r.start for r in item[1])):
        task, robot = tasks[key], group[0].robot
        assert {r.robot for r in group} == {robot} and robot in task["handling_s"]
        travel = float(np.hypot(*(np.array(task["start_site_m"]) - where[robot]))) / robots[robot]["speed_m_s"]
        duration = max(r.finish for r in group) - min(r.start for r in group)
        assert duration == pytest.approx(travel + task["handling_s"][robot], abs=1e-4)
        where[robot] = np.array(task["end_site_m"])


def test_joints_among_prebuilt_parts_are_no_task_even_where_those_rest_on_robot_work(shared_ifc):
    """AC20-FZK-Haus with its cast-in-place slabs and walls prebuilt: the upper slab and the walls on it
    are made by others once the beam under them stands, and their 36 joints among themselves come with
    them. The instance and CP-SAT's task graph list exactly the tasks simulate runs (343, not 379)."""
    from bimrobot.coordination.simulation import ConstructionSimulation
    from bimrobot.planning.benchmark import problem_for
    from bimrobot.planning.optimal_graph import task_graph

    problem, _, _ = problem_for(str(shared_ifc("AC20-FZK-Haus.ifc")))
    smart, fleet, site, elevations = problem.smart, problem.fleet, problem.site, problem.storey_elevations
    assert smart.prebuilt_later  # the case: prebuilt parts made once robot-built ones under them stand
    result = simulate(smart, fleet, site, storey_elevations=elevations, per_node=False)
    simulated = {_task_of(row, smart) for row in result.activities}
    instance = {t["id"] for t in build_instance(smart, fleet, site, elevations)["tasks"]}
    graph = {t.key for t in task_graph(smart, ConstructionSimulation(smart, fleet, site, storey_elevations=elevations))}
    assert instance == graph == simulated and len(simulated) == 343


def test_the_instance_file_is_deterministic_and_read_back(frame, tmp_path):
    path, *_ = frame
    out = tmp_path / "instance.json"
    assert main(["plan", "export", str(path), "--fleet", "fleet2", "-o", str(out)]) == 0
    first = out.read_bytes()
    assert main(["plan", "export", str(path), "--fleet", "fleet2", "-o", str(out)]) == 0  # its own file: replaced
    assert out.read_bytes() == first
    instance = load_instance(out)
    assert instance["version"] == 4 and instance["units"]["length"] == "m"
    assert {t["kind"] for t in instance["tasks"]} == {"transport", "position", "assemble"}


def test_a_broken_instance_is_refused_in_one_sentence(frame, tmp_path):
    _, smart, fleet, site, elevations = frame
    instance = json.loads(dumps(build_instance(smart, fleet, site, elevations)))
    path = tmp_path / "broken.json"
    instance["precedences"][0]["before"] = "transport:nothing"
    path.write_text(json.dumps(instance), encoding="utf-8")
    with pytest.raises(InputError, match="names a task or gate that is not in tasks or gates"):
        load_instance(path)
    instance["version"] = 99
    path.write_text(json.dumps(instance), encoding="utf-8")
    with pytest.raises(InputError, match="version 99, this bimrobot reads version 4"):
        load_instance(path)


def test_a_bad_fleet_or_a_foreign_file_exits_2(frame, tmp_path, capsys):
    path, *_ = frame
    assert main(["plan", "export", str(path), "--fleet", str(tmp_path / "none.yaml"), "-o", str(tmp_path / "i.json")]) == 2
    assert "none.yaml" in capsys.readouterr().err
    foreign = tmp_path / "mine.json"
    foreign.write_text("{}", encoding="utf-8")
    assert main(["plan", "export", str(path), "-o", str(foreign)]) == 2
    assert foreign.read_text(encoding="utf-8") == "{}"
