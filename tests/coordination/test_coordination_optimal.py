"""The CP-SAT schedule (bimrobot.planning.optimal) at scale: deterministic limits, never longer than the
market it starts from, a lower bound and its gap, and floor-by-floor solving for large builds."""

import importlib.util

import pytest

from bimrobot.bim.selection import DEFAULT_PREBUILT
from bimrobot.site.fleet import load_fleet
from bimrobot.coordination.generate import generated_frame
from bimrobot.coordination.market import handling_time
from bimrobot.coordination.simulation import ConstructionSimulation, simulate
from bimrobot.core.errors import InputError
from bimrobot.sco import build_smart_model

from bimrobot.planning.optimal import solve_optimal  # imports OR-Tools only when it solves
from bimrobot.planning.optimal_graph import task_graph

# found, not imported (tests/conftest.py): OR-Tools costs about 0.5 s of imports at collection otherwise
pytestmark = pytest.mark.skipif(importlib.util.find_spec("ortools") is None,
                                reason="CP-SAT needs OR-Tools: pip install 'bimrobot[optimize]'")

#: CP-SAT's deterministic time per solve (its own work units, the same on every machine), one worker
LIMITS = dict(workers=1, deterministic_limit=0.5, time_limit_s=600.0)


def _frame(nx: int, ny: int, floors: int):
    model = generated_frame(nx, ny, floors)
    return build_smart_model(model, prebuilt_classes=DEFAULT_PREBUILT), [s.elevation for s in model.storeys]


def _check_feasible(schedule, smart, fleet, elevations, site=None) -> None:
    """Every task starts after its predecessors end, and no robot does two things at once (seconds)."""
    sim = ConstructionSimulation(smart, fleet, site, storey_elevations=elevations)
    robots = {r.name: r for r in fleet.robots}
    tasks = task_graph(smart, sim)
    end = {t.key: schedule.start[t.key] + handling_time(robots[schedule.assignment[t.key]], t.request) for t in tasks}
    for t in tasks:
        for p in t.predecessors:
            assert schedule.start[t.key] >= end[p] - 0.011, (p, t.key)
    for name in robots:
        spans = sorted((schedule.start[k], end[k]) for k, r in schedule.assignment.items() if r == name)
        assert all(b[0] >= a[1] - 0.011 for a, b in zip(spans, spans[1:])), name
    assert max(end.values()) == pytest.approx(schedule.makespan, abs=0.02)


def test_best_found_is_a_schedule_no_longer_than_the_market_with_a_bound_and_its_gap():
    """The thesis' frame shape (2 x 2 columns, 4 beams: 28 tasks) with fleet2, within a deterministic limit."""
    smart, elevations = _frame(2, 2, 1)
    fleet = load_fleet("fleet2")
    schedule = solve_optimal(smart, fleet, storey_elevations=elevations, **{**LIMITS, "deterministic_limit": 0.2})
    market = simulate(smart, fleet, None, "least-cost", 0, (), elevations, per_node=False).makespan
    # its two floors solved together from home (the floors chained, in pairs) reach their bounds alone
    assert schedule.tasks == 28 and schedule.method == "floors chained"
    assert schedule.hinted_s == pytest.approx(market)
    assert schedule.makespan <= market + 0.05  # it starts from the market's own schedule
    # 144 bolts between a 60 s and a 30 s robot: at least 144 x 20 s of assembly, floor after floor
    assert 144 * 20 <= schedule.lower_bound <= schedule.makespan
    # each floor solved alone bounds its duration: the market is within 1.1 % of the optimum (3,601.7 s)
    assert schedule.lower_bound >= 3_580
    assert schedule.gap == pytest.approx((schedule.makespan - schedule.lower_bound) / schedule.makespan)
    _check_feasible(schedule, smart, fleet, elevations)


def test_the_two_column_frame_is_proved_optimal_and_beats_the_market():
    """10 tasks, fleet2: CP-SAT proves its schedule optimal (gap 0), 7 % shorter than the market's."""
    smart, elevations = _frame(2, 1, 1)
    fleet = load_fleet("fleet2")
    schedule = solve_optimal(smart, fleet, storey_elevations=elevations, **{**LIMITS, "deterministic_limit": 2.0})
    assert schedule.status == "OPTIMAL" and schedule.gap == 0
    assert schedule.makespan == pytest.approx(schedule.lower_bound)
    assert schedule.makespan <= 0.95 * schedule.hinted_s
    assert 0 < schedule.deterministic_s <= 2.0
    _check_feasible(schedule, smart, fleet, elevations)


def test_the_bound_counts_drives_between_points_and_the_positioning_stage():
    """3 x 2 columns, 7 beams (46 tasks), fleet2, a short deterministic limit: the bound alone (the whole
    not proved yet) shows the market within 1.4 % of the optimum (1.15 % measured). Without the drives between the
    points where a robot works, the wait for the columns to be positioned and each floor's own bound,
    it showed 4.7 % (5,359 s after 120 s)."""
    smart, elevations = _frame(3, 2, 1)
    fleet = load_fleet("fleet2")
    schedule = solve_optimal(smart, fleet, storey_elevations=elevations, **{**LIMITS, "deterministic_limit": 0.2})
    assert schedule.tasks == 46
    assert 5_550 <= schedule.lower_bound <= schedule.makespan <= schedule.hinted_s + 0.05
    assert (schedule.hinted_s - schedule.lower_bound) / schedule.hinted_s < 0.014
    # the column floor (optimum 1,830.2 s), before any search: each robot begins its first task only
    # after its own drive from home, and one assembly robot cannot begin before the second column stands
    # (1,815.4 s where all could begin when the earliest column is brought)
    assert schedule.floors[0]["bound_s"] >= 1_829.8
    # without CP-SAT's LP (the default) propagation closes the rest: the column floor alone is proved
    # within 0.2 units (3x2x2's, with the LP: unproved at 30 units; without: proved at 0.11)
    assert schedule.floors[0]["status"] == "OPTIMAL"
    assert schedule.floors[0]["best_s"] == pytest.approx(1_830.17, abs=0.005) == schedule.floors[0]["bound_s"]
    _check_feasible(schedule, smart, fleet, elevations)


def test_a_three_floor_frame_is_proved_optimal_above_the_sum_of_its_floors():
    """2 x 1 columns over two storeys (20 tasks, three floors), fleet2: each floor solved alone, from the
    best place each robot could have stopped below, is proved optimal; floors never overlap, so their sum
    bounds the whole, and the whole is proved optimal at or above it (6 % shorter than the market)."""
    smart, elevations = _frame(2, 1, 2)
    fleet = load_fleet("fleet2")
    schedule = solve_optimal(smart, fleet, storey_elevations=elevations, **{**LIMITS, "deterministic_limit": 1.0})
    assert schedule.tasks == 20 and schedule.method == "whole"
    assert [row["floor"] for row in schedule.floors] == [0, 1, 2]
    assert all(row["status"] == "OPTIMAL" and row["best_s"] == row["bound_s"] for row in schedule.floors)
    floors = sum(row["bound_s"] for row in schedule.floors)
    assert schedule.status == "OPTIMAL" and schedule.makespan == pytest.approx(schedule.lower_bound)
    assert floors - 0.01 <= schedule.lower_bound <= schedule.makespan <= 0.95 * schedule.hinted_s
    # the floors chained from where the robots stopped (a hint of the whole) cost 3.5 s more than the
    # floors alone: where a robot stops on one floor costs time on the next; the whole is no longer
    assert schedule.makespan <= schedule.chained_s and floors + 1.0 <= schedule.chained_s
    _check_feasible(schedule, smart, fleet, elevations)


def test_floors_chained_that_reach_their_bounds_alone_are_proved_optimal_without_the_whole_model():
    """One column over three storeys (9 tasks, three floors), fleet1: each floor solved again from where
    the robots stopped below reaches its bound alone, so the chain is optimal (the sum of the floors'
    bounds bounds every schedule) and the whole model is not solved."""
    smart, elevations = _frame(1, 1, 3)
    fleet = load_fleet("fleet1")
    schedule = solve_optimal(smart, fleet, storey_elevations=elevations, **{**LIMITS, "deterministic_limit": 0.5})
    floors = sum(row["bound_s"] for row in schedule.floors)
    assert schedule.method == "floors chained" and schedule.status == "OPTIMAL" and schedule.gap == 0
    assert schedule.makespan == pytest.approx(floors, abs=0.011) == schedule.chained_s
    assert schedule.makespan <= schedule.hinted_s + 0.05  # the market's, in the model's 0.01 s ticks
    _check_feasible(schedule, smart, fleet, elevations)


def test_the_same_limits_give_the_same_schedule():
    smart, elevations = _frame(2, 1, 1)
    fleet = load_fleet("fleet2")
    runs = [solve_optimal(smart, fleet, storey_elevations=elevations, hint=False, **{**LIMITS, "deterministic_limit": 0.3})
            for _ in range(2)]
    assert runs[0].makespan == runs[1].makespan and runs[0].assignment == runs[1].assignment


def test_a_large_build_is_solved_floor_by_floor_with_a_valid_bound():
    """Above ``whole_tasks`` the floors are solved one after the other; the bound is the sum of each
    floor's bound (floors never overlap), which no schedule, the market's included, can beat."""
    smart, elevations = _frame(2, 1, 2)
    fleet = load_fleet("fleet1")
    floors = solve_optimal(smart, fleet, storey_elevations=elevations, whole_tasks=10,
                           **{**LIMITS, "deterministic_limit": 0.2})
    assert floors.method == "by floor" and [row["floor"] for row in floors.floors] == [0, 1, 2]
    assert sum(row["tasks"] for row in floors.floors) == floors.tasks == 20
    assert floors.lower_bound == pytest.approx(sum(row["bound_s"] for row in floors.floors))
    assert 0 < floors.lower_bound <= floors.hinted_s and floors.lower_bound <= floors.makespan
    _check_feasible(floors, smart, fleet, elevations)


@pytest.mark.parametrize("whole_tasks", [400, 10])
def test_the_time_limit_bounds_the_whole_call_and_then_the_market_s_schedule_is_returned(whole_tasks):
    """A time limit that has passed before the first model is built (0 s): no model is built or solved,
    whole or floor by floor, and the market's schedule comes back, complete and feasible, with the reason.
    (On the 1,000-component frame, building the floors' models alone once took 629 s for a 60 s limit.)"""
    smart, elevations = _frame(2, 1, 2)
    fleet = load_fleet("fleet2")
    schedule = solve_optimal(smart, fleet, storey_elevations=elevations, whole_tasks=whole_tasks,
                             **{**LIMITS, "time_limit_s": 0.0})
    assert schedule.status == "FEASIBLE" and schedule.deterministic_s == 0 and schedule.floors == []
    assert schedule.makespan == pytest.approx(schedule.hinted_s) and 0 <= schedule.lower_bound <= schedule.makespan
    assert "time limit of 0 s passed" in schedule.note and "market's schedule" in schedule.note
    assert len(schedule.assignment) == schedule.tasks == 20
    _check_feasible(schedule, smart, fleet, elevations)


def test_too_many_tasks_are_refused_in_one_sentence():
    smart, elevations = _frame(2, 1, 1)
    with pytest.raises(InputError, match="the build has 10 tasks; the CP-SAT comparison is limited to 5"):
        solve_optimal(smart, load_fleet("fleet2"), storey_elevations=elevations, max_tasks=5)


def test_a_200_task_frame_is_proved_optimal_by_its_floors_chained_in_pairs():
    """Two columns and a beam per storey over 20 storeys (200 tasks, 21 floors), fleet2: each floor alone
    is proved optimal, and the floors chained two at a time (each pair from where the robots stopped
    below, so a floor's schedule is chosen with what its stops cost the floor above) reach the sum of the
    floors' bounds, which bounds every schedule: proved optimal without the whole model. Chained one at
    a time (before) it stayed 24.9 s above that sum, and the whole model did not close it in 5 units."""
    smart, elevations = _frame(2, 1, 20)
    fleet = load_fleet("fleet2")
    schedule = solve_optimal(smart, fleet, storey_elevations=elevations, **LIMITS)
    floors = sum(row["bound_s"] for row in schedule.floors)
    assert schedule.tasks == 200 and len(schedule.floors) == 21
    assert all(row["status"] == "OPTIMAL" for row in schedule.floors)
    assert schedule.method == "floors chained" and schedule.status == "OPTIMAL" and schedule.gap == 0
    assert schedule.makespan == pytest.approx(floors, abs=0.011) == schedule.chained_s
    assert schedule.makespan <= schedule.hinted_s + 0.05
    _check_feasible(schedule, smart, fleet, elevations)


def test_a_repeated_storey_is_solved_once():
    """2 x 2 columns over five storeys (140 tasks), fleet2: floors 2 and 3 (a storey's beams and the
    columns above) are the same problem to the tick, from the same places, so floor 3 takes floor 2's
    solve (its bound, and its schedule under its own task names) without solving again."""
    smart, elevations = _frame(2, 2, 5)
    fleet = load_fleet("fleet2")
    schedule = solve_optimal(smart, fleet, storey_elevations=elevations, **{**LIMITS, "deterministic_limit": 0.05})
    rows = schedule.floors
    assert [row["repeats"] for row in rows] == [False, False, False, True, False, False]
    assert (rows[3]["best_s"], rows[3]["bound_s"], rows[3]["status"]) == (rows[2]["best_s"], rows[2]["bound_s"], rows[2]["status"])
    assert schedule.lower_bound >= sum(row["bound_s"] for row in rows) - 0.011
    assert schedule.lower_bound <= schedule.makespan <= schedule.hinted_s + 0.05
    _check_feasible(schedule, smart, fleet, elevations)


def test_with_two_workers_the_floors_are_solved_at_once_one_worker_each():
    """With two CP-SAT workers the floors alone are solved two at a time, one worker each (a floor's proof
    comes sooner from one worker with a core to itself): each floor gets the same solve, bound and status
    as with one worker, so their rows are the same; the whole, with two workers, stays a valid schedule
    within its bound."""
    smart, elevations = _frame(2, 1, 2)
    fleet = load_fleet("fleet2")
    one, two = (solve_optimal(smart, fleet, storey_elevations=elevations, **{**LIMITS, "deterministic_limit": 1.0,
                                                                               "workers": workers}) for workers in (1, 2))
    assert [(r["best_s"], r["bound_s"], r["status"]) for r in two.floors] == [
        (r["best_s"], r["bound_s"], r["status"]) for r in one.floors]
    assert all(row["status"] == "OPTIMAL" for row in two.floors)
    assert sum(row["bound_s"] for row in two.floors) - 0.01 <= two.lower_bound <= two.makespan <= two.hinted_s + 0.05
    _check_feasible(two, smart, fleet, elevations)


def test_a_ground_floor_whose_columns_carry_the_next_floor_s_joints_is_solved_with_that_floor(shared_ifc):
    """ROOT-staal (221 tasks, site-crane): four of its nine ground-floor columns carry only joints of
    floor 1, so floor 0's work may go on while floor 1's is done, and the two are one run of floors for
    the solver. Every run then follows the one below, and each run solved alone bounds its share of the
    build: the bound rises above the constants (22,682.1 s when the ground floor held the floors alone
    back) and the floors chained give a schedule shorter than the market's. Its floor 2 (36 positionings for
    two cranes, 34 joints) starts from the list schedule that positions first the parts completing joints,
    not from the market's, which leaves the joints of its last parts to the end: 10 % under the market."""
    from bimrobot.planning.benchmark import problem_for

    problem, _, _ = problem_for(str(shared_ifc("ROOT-staal.ifczip")))
    schedule = solve_optimal(problem.smart, problem.fleet, problem.site, problem.storey_elevations, **LIMITS)
    assert schedule.tasks == 221
    assert [(row["floor"], row["tasks"]) for row in schedule.floors] == [(1, 57), (2, 106), (3, 25), (4, 33)]
    runs = sum(row["bound_s"] for row in schedule.floors)
    assert 25_000 <= runs - 0.01 <= schedule.lower_bound <= schedule.makespan
    # 27,288.9 against 30,298.4 s (29,559.9 from the market's schedule alone)
    assert schedule.makespan <= schedule.chained_s <= 0.92 * schedule.hinted_s
    _check_feasible(schedule, problem.smart, problem.fleet, problem.storey_elevations, problem.site)


def test_allocators_give_a_real_model_cp_sat_s_schedule_and_bound_by_default(shared_ifc):
    """GEELEN (69 tasks, site-crane) is within `allocators`' default --max-tasks (it was over the old 60,
    so it had no CP-SAT row): CP-SAT's row holds a schedule and a lower bound, no allocator beats the
    bound, and every gap is taken against it. CP-SAT is bounded by its own work (0.5 units), not by time."""
    from bimrobot.planning.benchmark import problem_for
    from bimrobot.planning.compare import ALLOCATORS_MAX_TASKS, compare_allocators

    problem, _, _ = problem_for(str(shared_ifc("GEELEN-Breedplaat_V1.ifc")))
    rows = compare_allocators(lambda: problem.smart, problem.fleet, problem.site, problem.storey_elevations, seeds=1,
                              max_tasks=ALLOCATORS_MAX_TASKS, **LIMITS)
    *others, cp_sat = rows
    assert cp_sat["tasks"] == 69 <= ALLOCATORS_MAX_TASKS
    bound = cp_sat["lower_bound_s"]
    assert 0 < bound <= cp_sat["makespan_s"] <= others[0]["makespan_s"]  # the least-cost market is its start
    for row in rows:
        assert row["makespan_s"] >= bound
        assert row["gap_pct"] == pytest.approx(100 * (row["makespan_s"] - bound) / bound, abs=0.01)
