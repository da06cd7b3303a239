"""The dispatching environment (bimrobot/Dispatch-v0): the market played in it is `simulate`, schedule for
schedule; any masked policy builds the whole frame; the observation's bounds hold. On the generated
chapter-4 steel frame (no IFC file): each test well under a second or two."""

import warnings
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from bimrobot.coordination.simulation import simulate
from bimrobot.core.errors import BimrobotError, InputError
from bimrobot.planning.dispatch import (ENV_ID, NODE_FEATURES, DispatchEnv, MarketPolicy, frame_problem, play,
                                       rebuild_observation, task_key)
from bimrobot.sco.states import State


def _rows(result):
    return [(a.id, str(a.activity), a.name, a.robot, a.start, a.finish, a.predecessors, a.aborted) for a in result.activities]


def _simulate(problem, evaluator="least-cost"):
    return simulate(problem.smart, problem.fleet, problem.site, evaluator, 0, problem.breakdowns,
                    problem.storey_elevations, per_node=problem.per_node)


@pytest.mark.parametrize("per_node", [True, False], ids=["per-node", "per-joint"])
def test_the_market_played_in_the_environment_is_simulate(per_node):
    """Every activity's robot, start and finish, the log and the events: identical; return = -makespan."""
    problem = frame_problem(per_node=per_node)
    reference = _simulate(problem)
    env = DispatchEnv(problem)
    total, result = play(env, MarketPolicy())
    assert _rows(result) == _rows(reference)
    assert result.log_lines == reference.log_lines and result.events == reference.events
    assert total == pytest.approx(-reference.makespan, abs=1e-6)
    assert reference.makespan == pytest.approx(3282.34 if per_node else 3617.62, abs=0.01)


def test_quickest_finish_breakdowns_and_idle_robots_to_the_yard_are_reproduced_too():
    """The market's other evaluator, a breakdown with repair, one for good, robots driving back to the yard."""
    base = frame_problem()
    problem = replace(base, site=replace(base.site, idle_robots="yard"),
                      breakdowns=(("TransportRobot11", 100.0, 50.0), ("AssemblyRobot31", 400.0)))
    for evaluator in ("quickest-finish", "least-cost"):
        reference = _simulate(problem, evaluator)
        assert any(a.aborted for a in reference.activities) or evaluator == "quickest-finish"
        _, result = play(DispatchEnv(problem), MarketPolicy(evaluator))
        assert _rows(result) == _rows(reference)
        # quickest finish also counts busy robots as bidders; the environment counts those that can start now
        strip = (lambda events: [{k: v for k, v in e.items() if k != "bidders"} for e in events])
        assert strip(result.events) == strip(reference.events)


def test_the_registered_environment_passes_gymnasiums_checker_without_a_warning():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = gym.make(ENV_ID)
        check_env(env.unwrapped)
    assert not [w for w in caught if "gymnasium" in str(w.filename)], [str(w.message) for w in caught]


def test_any_masked_policy_builds_the_whole_frame_and_respects_every_precedence():
    """A seeded random choice among the valid actions: every component Assembled, the return is minus the
    makespan, no row starts before its predecessors finish, no robot does two things at once."""
    env = DispatchEnv()
    rng = np.random.default_rng(7)
    obs, _ = env.reset(seed=7)
    total, done, truncated = 0.0, False, False
    while not (done or truncated):
        assert env.observation_space.contains(obs)
        obs, reward, done, truncated, info = env.step(int(rng.choice(np.flatnonzero(env.action_masks()))))
        assert reward <= 0 and not info["invalid_action"]
        total += reward
    result = env.result
    assert done and not truncated and "stalled" not in info
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    assert total == pytest.approx(-result.makespan, abs=1e-6)
    finish = {a.id: a.finish for a in result.activities}
    assert all(a.start >= finish[p] - 1e-9 for a in result.activities for p in a.predecessors)
    for robot in {a.robot for a in result.activities}:
        mine = sorted((a.start, a.finish) for a in result.activities if a.robot == robot)
        assert all(b[0] >= a[1] - 1e-9 for a, b in zip(mine, mine[1:]))


def test_the_first_decision_offers_the_first_floor_and_forbids_waiting():
    """At t = 0: the columns' transports are ready, to the two transport robots only; waiting would stall
    the build (nobody works yet), so it is masked; the beams wait for the columns."""
    env = DispatchEnv()
    obs, _ = env.reset(seed=0)
    keys, column = env.graph.keys, NODE_FEATURES.index
    ready = [keys[i] for i in np.flatnonzero(obs["node_features"][: len(keys), column("is_ready")])]
    columns = [c.id for c in env.sim.smart.components.values() if c.floor == 0 and not c.prebuilt]
    assert sorted(ready) == sorted(f"transport:{gid}" for gid in columns) and len(columns) == 4
    mask = env.action_masks()
    assert not mask[env.wait_action]
    chosen = {divmod(int(a), env.max_robots) for a in np.flatnonzero(mask)}
    assert {env.robot_names[r] for _, r in chosen} == {"TransportRobot11", "TransportRobot12"}
    beams = [i for i, k in enumerate(keys) if k.startswith("transport:") and k.split(":")[1] not in columns]
    assert beams and np.all(obs["node_features"][beams, column("earliest_start_s")] > 0)
    assert obs["node_mask"].sum() == len(keys) and obs["robot_mask"].sum() == 6


@pytest.mark.parametrize("per_node", [True, False], ids=["per-node", "per-joint"])
def test_the_earliest_start_is_a_lower_bound_of_the_markets_start(per_node):
    """Seen at t = 0, no task starts in the market's run before its earliest start; every graph node is
    some published task (or a floor gate)."""
    env = DispatchEnv(frame_problem(per_node=per_node))
    obs, _ = env.reset()
    bound = obs["node_features"][: len(env.graph.keys), NODE_FEATURES.index("earliest_start_s")]
    _, result = play(env, MarketPolicy())
    key_of, started = {}, {}
    for event in result.events:
        if event["event"] == "task_request":
            key_of[event["request"]] = task_key(event["activity"], event["component"], event["joint"], event["node"])
        elif event["event"] == "award":
            started.setdefault(key_of[event["request"]], event["time"])
    assert set(started) == {k for k in env.graph.keys if not k.startswith("gate:")}
    assert all(bound[env.graph_index[k]] <= t + 1e-3 for k, t in started.items())
    assert max(bound) > 0


def test_an_invalid_action_waits_or_takes_the_first_valid_award():
    env = DispatchEnv()
    env.reset(seed=0)
    first = int(np.flatnonzero(env.action_masks())[0])
    _, _, _, _, info = env.step(env.wait_action)  # nobody works yet: waiting is not allowed
    assert info["invalid_action"]
    assert env.sim.build.robots[env.robot_names[first % env.max_robots]].task is not None


def test_a_building_larger_than_the_padding_is_refused_in_one_sentence():
    env = DispatchEnv(max_tasks=16)
    with pytest.raises(InputError, match=r"the build has 49 tasks and floor gates, 6 robots and \d+ precedences; "
                                         r"this environment takes at most 16, 16 and 2048"):
        env.reset()


def test_one_environment_takes_buildings_of_any_size_drawn_at_reset():
    """A problem drawn from np_random at each reset: frames of different sizes in the same padded arrays;
    the same seed draws the same building."""
    def draw(rng):
        return frame_problem(size=(int(rng.integers(1, 4)), 2, int(rng.integers(1, 3))))

    env = DispatchEnv(draw, max_tasks=256, max_edges=1024)
    sizes = {seed: int(env.reset(seed=seed)[0]["node_mask"].sum()) for seed in range(6)}
    assert len(set(sizes.values())) > 1
    assert int(env.reset(seed=3)[0]["node_mask"].sum()) == sizes[3]
    total, result = play(env, MarketPolicy(), seed=3)
    assert total == pytest.approx(-result.makespan, abs=1e-6) and result.makespan > 0


def test_a_fleet_left_without_carriers_ends_the_episode_as_stalled():
    """Both transport robots break down for good: the build cannot finish, the episode ends and says why."""
    problem = replace(frame_problem(), breakdowns=(("TransportRobot11", 10.0), ("TransportRobot12", 10.0)))
    env = DispatchEnv(problem)
    env.reset(seed=0)
    done, info = False, {}
    while not done:
        _, _, done, truncated, info = env.step(int(np.flatnonzero(env.action_masks())[0]))
        assert not truncated
    assert "no working robot can transport" in info["stalled"] and env.result is None
    with pytest.raises(BimrobotError, match="call reset"):
        env.step(env.wait_action)


def _same_as_rebuilt_at_every_decision(env, policy, seed=0) -> int:
    """Step ``env`` with ``policy`` and compare each observation, key by key, with one rebuilt from
    nothing (``rebuild_observation``): same keys, dtypes and bits. Returns the decisions taken."""
    obs, _ = env.reset(seed=seed)
    done = truncated = False
    while True:
        expected = rebuild_observation(env)
        assert list(obs) == list(expected)
        for key, value in expected.items():
            assert obs[key].dtype == value.dtype and np.array_equal(obs[key], value), (key, env.decisions)
        if done or truncated:
            return env.decisions
        obs, _, done, truncated, _ = env.step(policy(env))


def test_the_kept_up_observation_is_the_rebuilt_one_bit_for_bit_on_the_frame():
    """The market per node and per joint, and with a breakdown (its task auctioned again), a robot out for
    good and idle robots driving back to the yard (travel from part way along a drive)."""
    base = frame_problem()
    problems = [base, frame_problem(per_node=False),
                replace(base, site=replace(base.site, idle_robots="yard"),
                        breakdowns=(("TransportRobot11", 100.0, 50.0), ("AssemblyRobot31", 400.0)))]
    for problem in problems:
        assert _same_as_rebuilt_at_every_decision(DispatchEnv(problem), MarketPolicy()) >= 28  # per joint: 28 tasks


def test_the_kept_up_observation_is_the_rebuilt_one_on_a_generated_building(tmp_path):
    """A generated precast frame of two floors (gates, its drawn fleet and site), a seeded random choice
    among the valid actions (waiting included), padded wider than the building; observed through the
    read-only views (``copy_observation=False``), which a caller cannot write into."""
    from bimrobot.planning.dispatch import simulate_problem
    from bimrobot.site.generated import generate
    from bimrobot.site.fleet import fleet_yaml
    from bimrobot.site.site import site_yaml

    made = generate("generated:precast:2x2x2:seed=3", tmp_path / "building.ifc")
    (tmp_path / "fleet.yaml").write_text(fleet_yaml(made.fleet, "test"), encoding="utf-8")
    (tmp_path / "site.yaml").write_text(site_yaml(made.site, "test"), encoding="utf-8")
    problem = simulate_problem([str(made.path), "--fleet", str(tmp_path / "fleet.yaml"), "--site", str(tmp_path / "site.yaml")])
    rng = np.random.default_rng(11)
    env = DispatchEnv(problem, max_tasks=256, max_robots=12, max_edges=1024, copy_observation=False)
    decisions = _same_as_rebuilt_at_every_decision(env, lambda e: int(rng.choice(np.flatnonzero(e.action_masks()))))
    assert decisions > len(env.graph.keys) // 2 and env.result is not None
    obs, _ = env.reset(seed=0)
    with pytest.raises(ValueError, match="read-only"):
        obs["travel_s"][0, 0] = 1.0


def test_the_local_observation_is_its_rebuilt_definition_and_passes_gymnasiums_checker():
    """``observation="local"``: the first ready tasks of each pool, their neighbourhood, the local earliest
    starts, travel of those tasks and the context, kept up between decisions, equal bit for bit to
    the definition rebuilt from nothing over whole episodes (the market per node and per joint, with a
    breakdown and robots driving to the yard; a seeded random policy on a larger frame, read-only views)."""
    base = frame_problem()
    problems = [base, frame_problem(per_node=False),
                replace(base, site=replace(base.site, idle_robots="yard"),
                        breakdowns=(("TransportRobot11", 100.0, 50.0), ("AssemblyRobot31", 400.0)))]
    for problem in problems:
        assert _same_as_rebuilt_at_every_decision(DispatchEnv(problem, observation="local"), MarketPolicy()) >= 28
    rng = np.random.default_rng(5)
    env = DispatchEnv(frame_problem(size=(3, 3, 2)), max_tasks=512, observation="local", copy_observation=False)
    assert _same_as_rebuilt_at_every_decision(env, lambda e: int(rng.choice(e.valid_actions()))) > 250
    check_env(DispatchEnv(observation="local"), skip_render_check=True)


def test_the_local_observation_holds_the_first_ready_tasks_of_each_pool_and_their_awards():
    """At every decision of the market on a frame whose floors hold more ready work than the local
    observation takes: at most LOCAL_READY ready tasks per activity, the first of its request pool (the
    market's order); every observed node within reach of one of them; ``local_actions`` are the valid
    awards of those tasks (and waiting where valid)."""
    from bimrobot.planning.dispatch_observation import LOCAL_READY

    env = DispatchEnv(frame_problem(size=(4, 4, 1)), max_tasks=512, observation="local", copy_observation=False)
    policy, done, truncated, most = MarketPolicy(), False, False, 0
    obs, _ = env.reset(seed=0)
    while not (done or truncated):
        held = set(env._local.ready)
        for activity, pool in env.sim.build.pending.items():
            first = {env._node_of(r) for r in sorted(pool)[:LOCAL_READY]}
            assert first == {v for v in held if env.graph.requests[v].activity == activity}
        most = max(most, sum(len(pool) for pool in env.sim.build.pending.values()) - len(held))
        assert held <= set(np.flatnonzero(obs["node_mask"]))
        valid = env.valid_actions()
        mine = [a for a in valid if a == env.wait_action or a // env.max_robots in held]
        assert env.local_actions() == (mine if mine else valid)  # no award of theirs and no waiting: every award
        obs, _, done, truncated, _ = env.step(policy(env))
    assert most > 0 and env.result is not None  # some ready work was left out of the observation
