"""The learned planner (bimrobot.planning.learned): one set of weights runs on buildings of any size;
imitation learns the market's choices; a saved policy round-trips with how it was trained; the planner's
schedule, run by simulate's own event simulation, respects every precedence. On generated steel frames
(no IFC file), one torch thread, seeded."""

import pytest
import torch as th

from bimrobot.coordination.simulation import simulate
from bimrobot.core.errors import InputError
from bimrobot.planning.dispatch import frame_problem, play
from bimrobot.planning.learned import (
    LearnedPlanner, LearnedPolicy, env_for, imitate, imitation_accuracy, load_policy,
    market_demonstrations, new_model, read_meta, save,
)
from bimrobot.sco.states import State

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
    planner = LearnedPlanner(path, guard=False)
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


@pytest.mark.parametrize("option", [["--seed", "-1"], ["--steps", "-5"], ["--imitation-steps", "-1"]])
def test_plan_train_refuses_a_negative_count_in_one_sentence_before_any_work(option, tmp_path, capsys):
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
    guarded, raw = LearnedPlanner(path), LearnedPlanner(path, guard=False)
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
