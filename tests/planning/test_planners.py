"""Planners behind one interface (issue 38): every planner's plan, executed by the one event simulation,
respects the precedences and the robots' capabilities; `--planner market` is simulate's default byte for
byte; a rule decides by its rule; an unknown planner is refused; CP-SAT's plan replayed keeps its
makespan. On the generated chapter-4 steel frame (no IFC file); CP-SAT with a small deterministic limit."""

import dataclasses

import pytest

from bimrobot.cli import main
from bimrobot.coordination.market import incapability
from bimrobot.planning.optimal_graph import task_graph
from bimrobot.coordination.simulation import ConstructionSimulation, simulate
from bimrobot.core.errors import InputError
from bimrobot.planning.dispatch import frame_problem
from bimrobot.planning.planners import PLANNERS, PORTFOLIO, plan, planner_for
from bimrobot.planning.rules import RuleDispatcher, _request_key, _scores
from bimrobot.core.tasks import Task

#: CP-SAT in tests: one worker and CP-SAT's deterministic time, so every machine finds the same plan
CPSAT = {"deterministic_s": 0.5, "time_limit_s": 600.0, "workers": 1}


def _by_task(smart, result) -> dict[str, tuple[str, float, float]]:
    """Task key (optimal.task_graph's) -> (robot, departure s, finish s); a joint's rows (one per node) merged."""
    rows: dict[str, tuple[str, float, float]] = {}
    for a in result.activities:
        if a.activity == Task.ASSEMBLE:
            node = a.node_id or a.name.split(" ", 1)[1]
            key = f"assemble:{smart.nodes[node].joint_id}"
        else:
            key = f"{a.activity}:{a.global_id}"
        robot, start, finish = rows.get(key, (a.robot, a.start, a.finish))
        rows[key] = (robot, min(start, a.start), max(finish, a.finish))
    return rows


@pytest.mark.parametrize("name", [p for p in PLANNERS if not p.startswith(("learned", "rollout"))])
def test_every_planner_builds_the_frame_respecting_precedences_and_capabilities(name):
    """Per joint (CP-SAT's tasks): every task done once, by a robot able to do it, never before what it
    waits for (the support, floor gate, transport-position and joint-member rules of optimal.task_graph)."""
    problem = frame_problem(per_node=False)
    result, stats = plan(name, problem, **(CPSAT if name == "cp-sat" else {}))
    member = stats.notes["portfolio_chosen"] if name == "portfolio" else name  # the portfolio runs its shortest member
    assert result.evaluator == ("least-cost" if member == "market" else member.removeprefix("market:"))
    sim = ConstructionSimulation(problem.smart, problem.fleet, problem.site, storey_elevations=problem.storey_elevations)
    tasks = task_graph(sim.smart, sim)
    done = _by_task(sim.smart, result)
    assert set(done) == {t.key for t in tasks}
    specs = {r.name: r for r in problem.fleet.robots}
    for t in tasks:
        robot, depart, _ = done[t.key]
        assert incapability(specs[robot], t.request) is None, (t.key, robot)
        for before in t.predecessors:
            assert done[before][2] <= depart + 1e-6, (before, t.key)
    assert stats.decisions == 28 and result.makespan > 0


def test_planner_market_is_simulate_byte_for_byte(tmp_path, capsys):
    """`simulate --planner market` writes the very files that `simulate` writes (the written-at stamp aside)."""
    common = ["simulate", "generated:2x2x1", "--fleet", "fleet2", "--no-progress", "--no-gantt"]
    assert main([*common, "-o", str(tmp_path / "default")]) == 0
    assert main([*common, "--planner", "market", "-o", str(tmp_path / "market")]) == 0
    files = sorted(p.name for p in (tmp_path / "default").iterdir() if p.name != ".bimrobot-output.json")
    assert files == sorted(p.name for p in (tmp_path / "market").iterdir() if p.name != ".bimrobot-output.json")
    assert "schedule.csv" in files
    for name in files:
        assert (tmp_path / "default" / name).read_bytes() == (tmp_path / "market" / name).read_bytes(), name


def test_a_rule_planner_decides_by_its_rule():
    """rule:longest-path gives first the ready task with the longest remaining path; rule:nearest, which
    ignores how fast a robot handles, builds the frame more slowly than the market (3,798 s against 3,282 s)."""
    problem = frame_problem()
    sim = ConstructionSimulation(problem.smart, problem.fleet, problem.site, storey_elevations=problem.storey_elevations,
                                 per_node=True)
    sim.start()
    scores = _scores(sim, "longest-path")
    ready = [r for pool in sim.build.pending.values() for r in pool]
    first = RuleDispatcher("longest-path").awards(sim)[0]
    assert scores[_request_key(sim, first.request)] == max(scores[_request_key(sim, r)] for r in ready)
    market = simulate(problem.smart, problem.fleet, problem.site, storey_elevations=problem.storey_elevations, per_node=True)
    nearest, _ = plan("rule:nearest", problem)
    assert [(a.robot, a.start) for a in nearest.activities] != [(a.robot, a.start) for a in market.activities]
    assert nearest.makespan == pytest.approx(3798.26, abs=0.01) and market.makespan == pytest.approx(3282.34, abs=0.01)


class _AllPairsNearest(RuleDispatcher):
    """rule:nearest by its definition: every (waiting task, idle capable robot) pair sorted by (drive, task
    priority, robot name), taken in that order while robot and task are free; and whether each round's
    awards are the rule's own."""

    def __init__(self):
        super().__init__("nearest")
        self.rounds = self.differed = 0

    def awards(self, sim):
        import numpy as np

        mine = super().awards(sim)
        idle = {a: set(n) for a, n in sim.build.idle.items()}
        where = {n: sim.position_now(sim.build.robots[n]) for names in idle.values() for n in names}
        pairs = sorted((float(np.hypot(*(r.start - where[n]))), r.priority, n, r)
                       for pool in sim.build.pending.values() for r in pool for n in idle[r.activity]
                       if not incapability(sim.build.robots[n].spec, r))
        by_definition, busy, given = [], set(), set()
        for _, _, name, request in pairs:
            if name not in busy and request.id not in given:
                by_definition.append((request.id, name))
                busy.add(name)
                given.add(request.id)
        self.rounds += 1
        self.differed += [(a.request.id, a.robot) for a in mine] != by_definition
        return mine


@pytest.mark.parametrize("per_node", [True, False])
def test_the_nearest_rule_awards_the_nearest_pair_again_and_again_at_every_round(per_node):
    """rule:nearest measures drives as arrays (for the thousands of waiting tasks of large buildings); at
    every round of the frame its awards are those of sorting every pair, in the same order."""
    problem = frame_problem(per_node=per_node)
    checked = _AllPairsNearest()
    run = simulate(problem.smart, problem.fleet, problem.site, storey_elevations=problem.storey_elevations,
                   per_node=per_node, dispatcher=checked)
    assert checked.rounds >= 25 and checked.differed == 0
    assert run.makespan == plan("rule:nearest", problem)[0].makespan


def test_an_awarded_request_leaves_its_pool_and_the_pool_stays_a_heap():
    """The simulation takes an award out of its pool in O(log n): the rest, by priority, is unchanged."""
    import heapq
    import random

    from bimrobot.coordination.run_state import remove_from_heap

    rng = random.Random(0)
    for _ in range(200):
        pool = [(rng.random(), i) for i in range(rng.randint(1, 60))]
        heapq.heapify(pool)
        gone = pool[rng.randrange(len(pool))]
        rest = sorted(r for r in pool if r is not gone)
        remove_from_heap(pool, gone)
        assert all(pool[(i - 1) // 2] <= pool[i] for i in range(1, len(pool)))
        assert sorted(pool) == rest


def test_an_unknown_planner_is_refused_in_one_sentence(tmp_path, capsys):
    with pytest.raises(InputError, match="unknown planner 'fastest'.*rule:longest-path.*cp-sat.*PATH.zip"):
        planner_for("fastest")
    assert main(["simulate", "generated:2x2x1", "--planner", "fastest", "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "unknown planner 'fastest'" in err and len(err.splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "out").exists()
    assert main(["simulate", "generated:2x2x1", "--planner", "cp-sat", "-o", str(tmp_path / "out")]) == 2
    assert "add --per-joint" in capsys.readouterr().err


@pytest.mark.parametrize("building", ["frame", "frame with a freestanding column"])
def test_cpsat_replayed_keeps_cpsat_makespan(building, request):
    """The simulation follows CP-SAT's robot per task and its order per robot: the executed makespan is
    CP-SAT's objective, up to CP-SAT's 0.01 s time unit (its times are rounded up, the run's are not),
    and below CP-SAT's lower bound by no more than that unit per task (the bound is the rounded-up
    problem's: CP-SAT proves 3,601.73 s on the frame, the run takes 3,601.69 s); no task needed to leave
    CP-SAT's order. With the freestanding column CP-SAT's floor gate must wait for its positioning as the
    simulation's does (before it did not: CP-SAT proved 3,619.59 s, the replay took 3,686.86 s and one
    task left CP-SAT's order)."""
    problem = frame_problem(per_node=False) if building == "frame" else request.getfixturevalue("freestanding_frame")
    result, stats = plan("cp-sat", problem, **CPSAT)
    notes, replay = stats.notes, stats.notes["replay"]
    rounding = 0.01 * notes["cpsat_tasks"]
    assert notes["cpsat_lower_bound_s"] - rounding <= result.makespan <= notes["cpsat_makespan_s"] + 1e-6
    assert notes["cpsat_makespan_s"] - result.makespan <= 0.01 * notes["cpsat_tasks"]
    assert replay.reordered == 0 and replay.unplanned == 0
    # CP-SAT starts from the portfolio's shortest schedule: never longer than it, nor than the market's
    members = {name: plan(name, problem)[0].makespan for name in PORTFOLIO}
    assert notes["cpsat_hint_s"] == pytest.approx(min(members.values()), abs=1e-6)
    assert members[notes["cpsat_hint"]] == min(members.values()) and notes["market_s"] == members["market"]
    assert result.makespan <= notes["cpsat_hint_s"] + 1e-6


def test_the_benchmark_bounds_every_planner_from_below():
    """`plan benchmark`'s rows: every planner's makespan at or above the bound (here the critical path of
    shortest handling times or the work per robot, CP-SAT left out), with the gap in per cent."""
    from bimrobot.planning.benchmark import bench_model, markdown

    names = ("market", "rule:nearest", "rule:longest-path", "rollout")
    entry = bench_model("generated:2x1x1", names, fleet="fleet2", log=lambda _: None)
    assert [r["planner"] for r in entry["rows"]] == list(names)
    assert entry["tasks"] == 10 and entry["bound_from"] in ("critical path", "work / robots")
    for row in entry["rows"]:
        assert row["makespan_s"] >= entry["lower_bound_s"] and row["gap_pct"] >= 0 and row["decisions"] == 10
    assert "| generated:2x1x1, fleet2 | 3 | 10 |" in markdown([entry], 60.0)
    searched = entry["rows"][-1]  # the search: its rollouts counted, never longer than the market
    assert 0 <= searched["search_rollouts"] <= searched["search_budget"] == 400
    assert searched["makespan_s"] <= entry["rows"][0]["makespan_s"]


def test_the_portfolio_runs_the_shortest_of_its_members():
    """`--planner portfolio` executes the shortest of the seven dispatching planners' schedules, exactly: its
    makespan is the minimum of the members played one by one, so never longer than the market's."""
    problem = frame_problem(per_node=False)
    alone = {name: plan(name, problem)[0].makespan for name in PORTFOLIO}
    result, stats = plan("portfolio", problem)
    assert result.makespan == pytest.approx(min(alone.values()), abs=1e-9)
    assert result.makespan <= alone["market"]
    assert stats.notes["portfolio_makespans_s"] == {k: round(v, 3) for k, v in alone.items()}
    assert alone[stats.notes["portfolio_chosen"]] == min(alone.values())


def test_the_completes_joints_rule_keeps_the_cranes_on_parts_whose_joints_can_be_made(shared_ifc):
    """GEELEN-Breedplaat (25 parts, 19 joints; two mobile cranes position, two bolt-up gangs join): each
    next part is the one that completes the most joints with those before it, so the joints follow the
    cranes instead of waiting for the last parts. Per joint 6,969.9 s: 15 % under the market (8,195.9 s),
    8 % under the best other portfolio member (shortest-handling, 7,592.6 s); per node 6,822.7 s against
    the market's 8,594.9 s."""
    from bimrobot.planning.benchmark import problem_for
    from bimrobot.planning.rules import completing_order

    # three parts in a triangle of joints and a part without joints: the third completes two, the loose one is last
    assert completing_order({"a": (0, 300.0), "b": (0, 600.0), "c": (0, 300.0), "loose": (0, 900.0)},
                            [["a", "b"], ["b", "c"], ["a", "c"]]) == ["b", "a", "c", "loose"]
    problem, _, _ = problem_for(str(shared_ifc("GEELEN-Breedplaat_V1.ifc")))
    alone = {name: plan(name, problem)[0].makespan for name in PORTFOLIO}
    others = min(v for name, v in alone.items() if name != "rule:completes-joints")
    assert alone["rule:completes-joints"] <= 0.86 * alone["market"] and alone["rule:completes-joints"] <= 0.93 * others
    per_node = dataclasses.replace(problem, per_node=True)
    assert plan("rule:completes-joints", per_node)[0].makespan <= 0.93 * plan("market", per_node)[0].makespan
