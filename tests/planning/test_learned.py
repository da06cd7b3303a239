"""The learned planner (bimrobot.planning.learned): one set of weights runs on buildings of any size;
imitation learns the market's choices; a saved policy round-trips with how it was trained; the planner's
schedule, run by simulate's own event simulation, respects every precedence. On generated steel frames
(no IFC file), one torch thread, seeded."""

import pytest

from bimrobot.coordination.simulation import simulate
from bimrobot.core.errors import InputError
from bimrobot.planning.dispatch import frame_problem, play
from bimrobot.sco.states import State


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """torch, Stable-Baselines3 and the learned planner (about 2.5 s of imports), imported when these tests
    run, not at collection (tests/conftest.py); one torch thread."""
    global th, LearnedPlanner, LearnedPolicy, env_for, imitate, imitation_accuracy, load_policy
    global market_demonstrations, new_model, read_meta, save
    import torch as th
    from bimrobot.planning.learned import (
        LearnedPlanner, LearnedPolicy, env_for, imitate, imitation_accuracy, load_policy,
        market_demonstrations, new_model, read_meta, save,
    )

    th.set_num_threads(1)


@pytest.fixture(scope="module")
def frame():
    return frame_problem()


@pytest.fixture(scope="module")
def imitated(frame, tmp_path_factory):
    """A policy taught the market's choices on the chapter-4 frame (bounded, seeded), saved once."""
    th.manual_seed(0)
    env = env_for(frame)
    model = new_model(env, seed=0)
    demonstrations = market_demonstrations([_Entry(frame)], (env.max_tasks, env.max_robots, env.max_edges))
    before = imitation_accuracy(model.policy, demonstrations)
    after = imitate(model.policy, demonstrations, steps=30, seed=0, batch=16, lr=1e-2)
    path = tmp_path_factory.mktemp("policy") / "policy.zip"
    save(model, path, {"command": "pytest imitated fixture", "seed": 0})
    return path, model, before, after, len(demonstrations[2])


class _Entry:
    def __init__(self, problem):
        self.problem = problem


def test_one_set_of_weights_plays_two_building_sizes(imitated):
    """The weights of the 49-node frame, loaded for a 3 x 2 x 1 frame padded to its own (larger) size:
    the same parameters, a valid award at every decision, the whole building assembled."""
    path, model, *_ = imitated
    big = env_for(frame_problem(size=(3, 2, 1)))
    assert big.max_tasks > 49 and big.action_space.n != model.action_space.n
    policy = load_policy(path, big)
    assert [p.shape for p in policy.parameters()] == [p.shape for p in model.policy.parameters()]
    learned = LearnedPolicy(policy)
    obs, _ = big.reset(seed=0)
    done = truncated = False
    while not (done or truncated):
        _, _, done, truncated, info = big.step(learned(big))
        assert not info["invalid_action"]
    assert done and all(c.state == State.ASSEMBLED for c in big.result.built.components.values())


def test_imitation_learns_the_markets_choices_on_the_frame(imitated):
    """30 seeded mini-batches of behaviour cloning: from under 60 % to at least 75 % of the market's 48 choices."""
    _, _, before, after, decisions = imitated
    assert decisions == 48
    assert before < 0.6 and after >= 0.75, (before, after)


def test_a_saved_policy_round_trips_with_how_it_was_trained(imitated, frame):
    """Loaded again, the policy gives the same greedy schedule; the zip says the command and seed."""
    path, model, *_ = imitated
    meta = read_meta(path)
    assert meta["command"] == "pytest imitated fixture" and meta["seed"] == 0 and "written by bimrobot" in meta["bimrobot"]
    env = env_for(frame)
    again = load_policy(path, env)
    for a, b in zip(again.state_dict().values(), model.policy.state_dict().values()):
        assert th.equal(a, b)
    first, _ = play(env, LearnedPolicy(model.policy), seed=0)
    second, _ = play(env, LearnedPolicy(again), seed=0)
    assert first == second


def test_the_learned_planners_schedule_respects_every_precedence(imitated, frame):
    """simulate with the planner's dispatcher: the policy's own schedule (same makespan), every component
    assembled, no activity before its predecessors, no robot doing two things at once."""
    path, *_ = imitated
    planner = LearnedPlanner(path, guard=False, search=0)
    _, played = planner.play(frame)
    replay = planner.dispatcher(frame)
    result = simulate(frame.smart, frame.fleet, frame.site, "least-cost", 0, (), frame.storey_elevations,
                      per_node=frame.per_node, dispatcher=replay)
    assert result.makespan == pytest.approx(played.makespan, abs=1e-9)
    assert replay.fallbacks == 0 and not replay.remaining
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    finish = {a.id: a.finish for a in result.activities}
    assert all(a.start >= finish[p] - 1e-9 for a in result.activities for p in a.predecessors)
    for robot in {a.robot for a in result.activities}:
        mine = sorted((a.start, a.finish) for a in result.activities if a.robot == robot)
        assert all(b[0] >= a[1] - 1e-9 for a, b in zip(mine, mine[1:]))


def test_a_missing_or_foreign_policy_file_is_refused_in_one_sentence(tmp_path, frame):
    with pytest.raises(InputError, match="no such policy file"):
        LearnedPlanner(tmp_path / "none.zip")
    (tmp_path / "bad.zip").write_text("not a zip")
    with pytest.raises(InputError, match="not a saved policy zip"):
        load_policy(tmp_path / "bad.zip", env_for(frame))


def test_plan_train_writes_an_imitation_policy_that_loads_with_its_own_observation(tmp_path, monkeypatch, frame):
    """imitation.zip (the policy before PPO) says which observation it reads, so it plays as trained
    (it used to be read as one of the full observation and refused). On a pool of the frame alone."""
    from bimrobot.cli import main
    from bimrobot.planning import learned_train
    from bimrobot.planning.learned_pool import PoolEntry

    from bimrobot.planning.dispatch import MarketPolicy

    market = play(env_for(frame), MarketPolicy(), seed=0)[1].makespan
    monkeypatch.setattr(learned_train, "training_pool", lambda seed, specs, per_joint=False: [PoolEntry("frame", frame, market)])
    out = tmp_path / "run"
    assert main(["plan", "train", "--steps", "0", "--imitation-steps", "5", "--teacher", "market",
                 "--observation", "local", "--hidden", "8", "-o", str(out)]) == 0
    imitation = LearnedPlanner(out / "imitation.zip", search=0, guard=False)
    assert read_meta(out / "imitation.zip")["observation"] == imitation.observation == "local"
    assert imitation.play(frame)[1].makespan > 0


@pytest.mark.parametrize("option", [["--seed", "-1"], ["--steps", "-5"], ["--imitation-steps", "-1"],
                                    ["--observation", "local", "--teacher", "pilot"], ["--hidden", "0"]])
def test_plan_train_refuses_a_negative_count_or_the_pilot_on_the_local_observation_before_any_work(option, tmp_path, capsys):
    from bimrobot.cli import main

    code = main(["plan", "train", *option, "-o", str(tmp_path / "run")])
    err = capsys.readouterr().err
    assert code == 2 and option[0] in err and "Traceback" not in err
    assert not (tmp_path / "run").exists()


def test_the_guarded_planner_is_never_longer_than_the_market_and_says_which_plan_it_used(imitated, frame):
    """The "never worse" rule: the planner plays its policy and the least-cost market and simulate runs the
    shorter schedule exactly; without the guard it runs the policy's own."""
    from bimrobot.planning.dispatch import MarketPolicy

    path, *_ = imitated
    _, market = play(env_for(frame), MarketPolicy(), seed=0)
    guarded, raw = LearnedPlanner(path, search=0), LearnedPlanner(path, guard=False, search=0)
    replay = guarded.dispatcher(frame)
    result = simulate(frame.smart, frame.fleet, frame.site, "least-cost", 0, (), frame.storey_elevations,
                      per_node=frame.per_node, dispatcher=replay)
    last = guarded.last
    assert last["market_s"] == pytest.approx(market.makespan, abs=1e-9)
    assert result.makespan == pytest.approx(min(last["policy_s"], last["market_s"]), abs=1e-9)
    assert result.makespan <= market.makespan + 1e-9 and replay.fallbacks == 0
    assert last["chosen"] == ("policy" if last["policy_s"] <= last["market_s"] else "market")
    raw.dispatcher(frame)
    assert raw.last == {"policy_s": last["policy_s"], "market_s": None, "chosen": "policy"}


# ---------------------------------------------------------------- the pilot teacher and the advised policy
@pytest.fixture(scope="module")
def piloted(frame):
    """The pilot's decisions on the chapter-4 frame (padded to its own size)."""
    from bimrobot.planning.learned import pilot_demonstrations, sizes

    return pilot_demonstrations(frame, sizes(frame))


def test_the_pilot_teacher_is_never_longer_than_the_market_and_its_labels_replay_its_schedule(piloted, frame):
    """The pilot (the advisers' first choices tried, the market finishing) on the frame: a schedule no
    longer than the market's (here shorter), and its recorded actions, replayed, give that schedule."""
    observations, masks, actions, pilot_s, market_s = piloted
    assert pilot_s <= market_s + 1e-9 and pilot_s < market_s - 1.0, (pilot_s, market_s)
    assert len(observations) == len(masks) == len(actions) and all(m[a] for m, a in zip(masks, actions))
    env = env_for(frame)
    env.reset(seed=0)
    done = truncated = False
    for action in actions:
        assert not (done or truncated)
        _, _, done, truncated, _ = env.step(action)
    assert done and env.result.makespan == pytest.approx(pilot_s, abs=1e-9)


def test_the_advice_does_not_change_the_build_and_names_the_markets_next_award(frame):
    """Reading the advisers' awards at every decision leaves the market's schedule as it was; the market
    adviser's first award is the action MarketPolicy plays."""
    from bimrobot.planning.dispatch import MarketPolicy
    from bimrobot.planning.learned import ADVISERS, observe

    _, alone = play(env_for(frame), MarketPolicy(), seed=0)
    env, market = env_for(frame), MarketPolicy()
    env.reset(seed=0)
    done = truncated = False
    first = True
    while not (done or truncated):
        obs = observe(env)
        action = market(env)
        if first:
            node, robot = divmod(action, env.max_robots)
            assert obs["advice"][node, robot, ADVISERS.index("market")] == 1.0
            assert obs["order_in_kind"][node] >= 1 and obs["order_in_kind"].max() >= 1
            first = False
        _, _, done, truncated, _ = env.step(action)
    assert env.result.makespan == pytest.approx(alone.makespan, abs=1e-9)


def test_an_advised_policy_learns_the_pilot_and_plays_a_larger_building_after_loading(piloted, frame, tmp_path):
    """30 seeded mini-batches of the pilot's 49 decisions: at least 80 % of them reproduced (the advice
    shows each planner's next award); saved and loaded for a 3 x 2 x 1 frame, it assembles that building."""
    from bimrobot.planning.learned import Advised, pilot_teacher, sizes

    th.manual_seed(0)
    model = new_model(Advised(env_for(frame)), seed=0)
    demonstrations, taught = pilot_teacher([_Spec("frame", frame)], sizes(frame))
    assert taught == {"frame": pytest.approx(piloted[3], abs=1e-3)}
    assert len(demonstrations[2]) == 49
    accuracy = imitate(model.policy, demonstrations, steps=30, seed=0, batch=16, lr=1e-2)
    assert accuracy >= 0.8, accuracy
    path = save(model, tmp_path / "advised.zip", {"command": "pytest", "seed": 0, "teacher": "pilot"})
    big = frame_problem(size=(3, 2, 1))
    planner = LearnedPlanner(path, guard=False)
    _, result = planner.play(big)
    assert all(c.state == State.ASSEMBLED for c in result.built.components.values())
    assert planner.meta["teacher"] == "pilot"


class _Spec(_Entry):
    def __init__(self, spec, problem):
        super().__init__(problem)
        self.spec = spec


def test_the_shipped_policy_says_how_it_was_trained_and_the_planner_is_not_longer_than_the_market(frame):
    """``--planner learned``: a policy of the local observation trained by one command with a seed, on
    generated buildings only, by the search teacher (`--teacher search --observation local`); on the
    chapter-4 frame (fleet2) the guarded planner is no longer than the least-cost market."""
    from bimrobot.planning.dispatch import MarketPolicy
    from bimrobot.planning.learned import DEFAULT_POLICY

    meta = read_meta(DEFAULT_POLICY)
    assert meta["command"].startswith("bimrobot plan train --seed ") and isinstance(meta["seed"], int)
    assert meta["teacher"] == "search" and meta["observation"] == "local" and meta["advisers"] == []
    assert all(spec.startswith("generated:") for spec in meta["training_buildings"])
    _, market = play(env_for(frame), MarketPolicy(), seed=0)
    planner = LearnedPlanner(search=0)  # learned:greedy
    planner.dispatcher(frame)
    assert min(planner.last["policy_s"], planner.last["market_s"]) <= market.makespan + 1e-9
    assert planner.last["market_s"] == pytest.approx(market.makespan, abs=1e-9)


def test_the_fast_greedy_choice_is_sb3_contribs_at_every_decision(frame):
    """The shipped policy (local observation) embedding only the observed nodes and scoring only the
    observed ready tasks' awards (a lone valid action taken without the network) picks, at every decision of the chapter-4 frame, the action of sb3-contrib's masked
    distribution over every pair; the policy's makespan there is the documented 3,797.2 s."""
    from bimrobot.planning.learned import DEFAULT_POLICY

    env = env_for(frame, copy_observation=False, observation="local")
    fast = _fast_choices_are_sb3_contribs(load_policy(DEFAULT_POLICY, env), env)
    assert fast.decisions == env.decisions == 48 and fast.cpu["network"] > 0.0
    assert env.result.makespan == pytest.approx(3797.2, abs=0.05)


def test_the_kept_forward_gives_a_fresh_ones_logits_bit_for_bit():
    """The shipped policy keeps, between the decisions of an episode, each node's MLP output (computed again
    only where the node's state or earliest start changed) and its buffers (the observed edges, the node
    rows, the message passing's inputs): at every decision of a two-storey frame its logits are, bit for
    bit, those of a forward made new at that decision (every observed node's MLP at once, new arrays), so
    the kept state never changes a choice."""
    import numpy as np

    from bimrobot.planning.learned import DEFAULT_POLICY, _candidates

    env = env_for(frame_problem(size=(2, 2, 2)), copy_observation=False, observation="local")
    policy = load_policy(DEFAULT_POLICY, env)
    kept = LearnedPolicy(policy)
    env.reset(seed=0)
    done = truncated = False
    compared = 0
    while not (done or truncated):
        if len(actions := _candidates(env)) > 1:
            logits = kept._logits(env, actions).numpy()
            assert np.array_equal(logits, LearnedPolicy(policy)._logits(env, actions).numpy()), env.decisions
            compared += 1
        _, _, done, truncated, _ = env.step(kept(env))
    assert done and compared > 100 and kept.forward._kept[0] is not None


@pytest.mark.parametrize("hidden", [32, 16])
def test_a_local_policy_scores_its_neighbourhood_as_the_padded_arrays_do(frame, tmp_path, hidden):
    """A policy that reads the local observation (``observation="local"``, the market imitated briefly),
    of width 32 or 16 (``plan train --hidden``): its greedy choice from the observed nodes alone (gathered
    and renumbered) is sb3-contrib's over the padded arrays at every decision of a two-storey frame (a
    floor gate's edges read once), it builds it, it loads back with its width, and it says which
    observation it reads: a full environment is refused in one sentence."""
    th.manual_seed(0)
    env = env_for(frame, observation="local")
    model = new_model(env, seed=0, hidden=hidden)
    demonstrations = market_demonstrations([_Entry(frame)], (env.max_tasks, env.max_robots, env.max_edges),
                                           observation="local")
    assert "context" in demonstrations[0]
    imitate(model.policy, demonstrations, steps=10, seed=0, batch=16, lr=1e-2)
    path = save(model, tmp_path / "local.zip", {"command": "pytest", "seed": 0, "observation": "local"})
    big = env_for(frame_problem(size=(2, 2, 2)), copy_observation=False, observation="local")  # two floors: a gate
    fast = _fast_choices_are_sb3_contribs(load_policy(path, big), big)
    assert fast.cpu["network"] > 0.0 and fast.policy.features_extractor.hidden == hidden
    assert LearnedPlanner(path).observation == "local"
    with pytest.raises(InputError, match="reads the local observation, this environment gives the full one"):
        load_policy(path, env_for(frame))


def _fast_choices_are_sb3_contribs(policy, env):
    """Play one episode of ``env`` with sb3-contrib's masked choice over every pair, asserting at every
    decision that :class:`LearnedPolicy`'s fast path picks the same action and, with the local observation,
    that the numpy forward (``learned_forward.LocalForward``, the default there) gives torch's logits
    within 1e-4; return the timed fast policy."""
    from bimrobot.planning.learned import _candidates

    fast, full = LearnedPolicy(policy, timed=True), LearnedPolicy(policy, fast=False)
    torch_fast = LearnedPolicy(policy, numpy=False)
    assert (fast.forward is not None) == (env.unwrapped.observation == "local") and torch_fast.forward is None
    env.reset(seed=0)
    done = truncated = False
    while not (done or truncated):
        action = full(env)
        assert fast(env) == action, env.decisions
        if fast.forward is not None and len(actions := _candidates(env)) > 1:
            assert th.allclose(fast._logits(env, actions), torch_fast._logits(env, actions), rtol=0.0, atol=1e-4)
        _, _, done, truncated, _ = env.step(action)
    assert done, "the episode was truncated"
    return fast
