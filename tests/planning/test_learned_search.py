"""The learned planner's decision-time search (bimrobot.planning.learned_search): the policy proposes,
rollouts decide. Its schedule is never longer than the portfolio's nor the market's, simulate executes
exactly the planned schedule, the budget bounds the rollouts, and plan.json says what the search did.
On the generated chapter-4 frame per joint (28 tasks) with a few rollouts; one torch thread."""

import json

import pytest

from bimrobot.coordination.simulation import simulate
from bimrobot.core.errors import InputError
from bimrobot.planning.dispatch import frame_problem
from bimrobot.planning.learned_search import search
from bimrobot.planning.planners import plan, plan_record
from bimrobot.sco.states import State


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """One torch thread; torch itself (about 2 s of imports) is imported when these tests run, not at
    collection (tests/conftest.py)."""
    import torch

    torch.set_num_threads(1)


@pytest.fixture(scope="module")
def frame():
    return frame_problem(per_node=False)


@pytest.fixture(scope="module")
def baselines(frame):
    """The market's and the portfolio's makespans (s) on the frame, each executed by the event simulation."""
    return plan("market", frame)[0].makespan, plan("portfolio", frame)[0].makespan


@pytest.fixture(scope="module")
def searched(frame):
    """The shipped policy with a search of 12 rollouts on the frame, planned and executed by simulate."""
    from bimrobot.planning.learned import LearnedPlanner

    planner = LearnedPlanner(search=12)
    replay = planner.dispatcher(frame)
    result = simulate(frame.smart, frame.fleet, frame.site, "least-cost", 0, (), frame.storey_elevations,
                      per_node=frame.per_node, dispatcher=replay)
    return planner.last, replay, result


def test_the_search_is_never_longer_than_the_portfolio_nor_the_market(searched, baselines):
    last, _, result = searched
    market, portfolio = baselines
    assert last["market_s"] == pytest.approx(market, abs=1e-3)
    assert last["portfolio_s"] == pytest.approx(portfolio, abs=1e-3)
    assert result.makespan <= portfolio + 1e-6 <= market + 1e-6
    assert result.makespan <= last["policy_greedy_s"] + 1e-6  # the policy's own schedule is a starting point too


def test_simulate_executes_exactly_the_searched_schedule(searched):
    last, replay, result = searched
    assert result.makespan == pytest.approx(last["planned_s"], abs=1e-3)
    assert replay.fallbacks == 0 and not replay.remaining
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    finish = {a.id: a.finish for a in result.activities}
    assert all(a.start >= finish[p] - 1e-9 for a in result.activities for p in a.predecessors)


@pytest.mark.parametrize("budget", [0, 3])
def test_the_budget_bounds_the_rollouts(frame, baselines, budget):
    """The search without a policy (the ``rollout`` planner, the ablation): at most ``budget`` rollouts;
    with none it is the portfolio's schedule."""
    found = search(frame, None, budget)
    assert found.rollouts <= budget and found.budget == budget
    assert found.makespan_s <= baselines[1] + 1e-6
    if budget == 0:
        assert found.makespan_s == pytest.approx(baselines[1], abs=1e-9) and found.passes == 0


def test_the_simulated_decisions_bound_the_portfolio_and_the_rollouts(frame, baselines):
    """A decision budget of 3 episodes of the frame (its 29 nodes each): the market and the next two
    portfolio members are played, no rollout, whatever the rollout budget; never longer than the market."""
    found = search(frame, None, 400, decisions=3 * 29)
    assert list(found.members_s) == ["market", "market:quickest-finish", "rule:most-successors"]
    assert found.rollouts == 0 and found.budget == 0 and found.passes == 0
    assert found.makespan_s <= baselines[0] + 1e-6
    assert search(frame, None, 400, decisions=29).members_s.keys() == {"market"}


def test_plan_json_records_the_budget_the_rollouts_and_each_makespan(frame):
    result, stats = plan("learned", frame, search=4)
    record = json.loads(plan_record("learned", result, stats))
    assert record["planner"] == "learned" and record["search_budget"] == 4 and 0 <= record["search_rollouts"] <= 4
    assert record["makespan_s"] == pytest.approx(record["planned_s"], abs=2e-3)
    assert record["planned_s"] <= record["portfolio_s"] <= record["market_s"]
    assert record["policy_greedy_s"] > 0 and record["search_started_from"] in ("policy", record["portfolio_member"])


def test_a_negative_budget_is_refused_in_one_sentence():
    from bimrobot.planning.learned import LearnedPlanner

    with pytest.raises(InputError, match="search budget must be 0 or more rollouts"):
        LearnedPlanner(search=-1)


def test_the_search_as_a_teacher_labels_its_own_schedule(baselines):
    """``plan train --teacher search``: the decisions along the search's schedule on a training building
    (here the frame, per joint, 4 rollouts), one advised observation per action, its makespan no longer
    than the portfolio's."""
    from bimrobot.planning.learned import sizes
    from bimrobot.planning.learned_search import search_teacher

    class Entry:
        spec, problem = "frame", frame_problem(per_node=False)

    (obs, masks, actions), taught = search_teacher([Entry()], sizes(Entry.problem), budget=4)
    assert len(actions) == len(masks) == len(obs["advice"]) >= 28
    assert all(masks[i, a] for i, a in enumerate(actions))
    assert taught["frame"] <= baselines[1] + 1e-3


@pytest.mark.parametrize("fleet, per_node, shorter", [("fleet1", False, "policy"), ("fleet2", True, "market")])
def test_with_the_market_and_the_policy_only_the_market_runs_beside_the_policy(fleet, per_node, shorter):
    """A decision budget of two episodes (the largest buildings): the market's makespan comes from
    simulate's own run in a forked process while the policy plays, and the plan is the shorter of the two
    schedules with its actions and awards, as the market's and the policy's episodes give them. The
    shipped policy's schedule is the shorter on the frame with fleet1 per joint, the market's with
    fleet2 per node (both branches)."""
    from bimrobot.planning.learned import LearnedPolicy, env_for, load_policy, DEFAULT_POLICY
    from bimrobot.planning.learned_advice import RolloutEnv, complete_build
    from bimrobot.planning.learned_search import awards_of

    problem = frame_problem(fleet, per_node=per_node)
    env = env_for(problem, copy_observation=False, observation="local")
    found = search(problem, LearnedPolicy(load_policy(DEFAULT_POLICY, env)), 400, env=env, decisions=2 * env.max_tasks)
    market = complete_build(RolloutEnv(problem, env.max_tasks, env.max_robots, env.max_edges), [])
    greedy = complete_build(env, [], LearnedPolicy(load_policy(DEFAULT_POLICY, env)))
    best = greedy if greedy[0] < market[0] - 1e-9 else market
    assert list(found.members_s) == ["market"] and found.rollouts == found.budget == found.passes == 0
    assert found.market_s == pytest.approx(market[0], abs=1e-9) and found.policy_s == greedy[0]
    assert (found.makespan_s, found.actions, found.awards) == best
    assert found.started_from == ("policy" if best is greedy else "market") == shorter
    assert awards_of(problem, found.actions)[0] == found.awards


def test_a_forked_market_run_that_dies_is_computed_here_instead(monkeypatch):
    """Where the forked process dies without a result (killed, out of memory), the market's makespan
    comes from simulate's run in this process: the same plan."""
    import os

    import bimrobot.planning.learned_search as learned_search
    from bimrobot.core.forked import Forked
    from bimrobot.planning.learned import LearnedPolicy, env_for, load_policy, DEFAULT_POLICY

    problem = frame_problem(per_node=False)
    env = env_for(problem, copy_observation=False, observation="local")
    policy = LearnedPolicy(load_policy(DEFAULT_POLICY, env))
    found = search(problem, policy, 400, env=env, decisions=2 * env.max_tasks)
    monkeypatch.setattr(learned_search, "_fork", lambda function, *args: Forked(os._exit, (3,)))
    again = search(problem, policy, 400, env=env, decisions=2 * env.max_tasks)
    assert (again.makespan_s, again.actions, again.market_s) == (found.makespan_s, found.actions, found.market_s)


def test_cpsat_as_a_teacher_labels_its_schedule_the_same_on_every_run(baselines):
    """``plan train --teacher cp-sat``: the decisions along CP-SAT's schedule on a training building per
    joint (here the frame, 1 deterministic second per solve): one observation and a valid action per
    decision, replaying CP-SAT's executed makespan, no longer than the portfolio's it starts from, and the
    same labels on a second run (CP-SAT's deterministic clock, one worker)."""
    from bimrobot.planning.learned import sizes
    from bimrobot.planning.learned_train import cpsat_teacher

    class Entry:
        spec, problem = "frame", frame_problem(per_node=False)

    (obs, masks, actions), taught = cpsat_teacher([Entry()], sizes(Entry.problem), observation="local", units=1.0)
    assert len(actions) == len(masks) == len(obs["node_mask"]) >= 28
    assert all(masks[i, a] for i, a in enumerate(actions))
    executed = plan("cp-sat", Entry.problem, deterministic_s=1.0, time_limit_s=3600)[0].makespan
    assert taught["frame"] == pytest.approx(executed, abs=1e-3) and taught["frame"] <= baselines[1] + 1e-3
    (_, _, again), taught_again = cpsat_teacher([Entry()], sizes(Entry.problem), observation="local", units=1.0)
    assert (again == actions).all() and taught_again == taught
