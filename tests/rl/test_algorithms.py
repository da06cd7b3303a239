"""The Double / Dueling DQN extensions of SB3's DQN, checked against hand-computed numbers."""

from __future__ import annotations

import numpy as np
import pytest

from bimrobot.core.errors import InputError


@pytest.fixture(autouse=True, scope="module")
def _heavy_imports():
    """torch and Stable-Baselines3 (about 3 s of imports) and the tensors below, made when these tests
    run, not at collection."""
    global th, DQN, ReplayBufferSamples, DoubleDQN, DuelingDQNPolicy, DuelingQNetwork, dueling_aggregate
    global hyperparameters, td_targets, REWARDS, DONES, NEXT_Q_TARGET, NEXT_Q_ONLINE
    import torch as th
    from stable_baselines3 import DQN
    from stable_baselines3.common.type_aliases import ReplayBufferSamples

    from bimrobot.rl.algorithms import (
        DoubleDQN,
        DuelingDQNPolicy,
        DuelingQNetwork,
        dueling_aggregate,
        hyperparameters,
        td_targets,
    )

    REWARDS = th.tensor([[1.0], [0.5], [-1.0]])
    DONES = th.tensor([[0.0], [1.0], [0.0]])
    NEXT_Q_TARGET = th.tensor([[1.0, 5.0], [2.0, 3.0], [4.0, -2.0]])
    NEXT_Q_ONLINE = th.tensor([[3.0, 1.0], [0.0, 4.0], [-1.0, 0.0]])


@pytest.fixture
def algo_class(request):
    """The algorithm class named by the test's parameter (imported by _heavy_imports)."""
    return globals()[request.param]


GAMMA = 0.9


def test_dqn_target_is_the_target_networks_max():
    targets = td_targets(REWARDS, DONES, GAMMA, NEXT_Q_TARGET)
    # 1 + 0.9 * 5; terminal: 0.5; -1 + 0.9 * 4
    assert th.allclose(targets, th.tensor([[5.5], [0.5], [2.6]]))


def test_double_dqn_target_takes_the_online_argmax_and_the_target_value():
    targets = td_targets(REWARDS, DONES, GAMMA, NEXT_Q_TARGET, next_q_online=NEXT_Q_ONLINE)
    # online argmax: action 0 -> target 1.0; terminal; online argmax action 1 -> target -2.0
    assert th.allclose(targets, th.tensor([[1.9], [0.5], [-2.8]]))


def _model_with_fixed_batch(algo_class, batch: ReplayBufferSamples):
    model = algo_class("MlpPolicy", "CartPole-v1", learning_rate=0.0, gamma=GAMMA, seed=0, device="cpu")
    model._setup_learn(total_timesteps=1)
    model.replay_buffer.sample = lambda batch_size, env=None: batch
    return model


def _cartpole_batch() -> ReplayBufferSamples:
    rng = np.random.default_rng(0)
    obs = th.tensor(rng.normal(size=(3, 4)), dtype=th.float32)
    next_obs = th.tensor(rng.normal(size=(3, 4)), dtype=th.float32)
    return ReplayBufferSamples(obs, th.tensor([[0], [1], [1]]), next_obs, DONES, REWARDS)


@pytest.mark.parametrize("algo_class,double", [("DQN", False), ("DoubleDQN", True)], indirect=["algo_class"])
def test_train_step_loss_uses_the_expected_target(algo_class, double):
    batch = _cartpole_batch()
    model = _model_with_fixed_batch(algo_class, batch)
    with th.no_grad():
        q_online_next = model.q_net(batch.next_observations)
        q_target_next = model.q_net_target(batch.next_observations)
        expected_target = td_targets(
            batch.rewards, batch.dones, GAMMA, q_target_next, q_online_next if double else None
        )
        current = th.gather(model.q_net(batch.observations), 1, batch.actions)
        expected_loss = th.nn.functional.smooth_l1_loss(current, expected_target).item()
    model.train(gradient_steps=1, batch_size=3)
    assert model.logger.name_to_value["train/loss"] == pytest.approx(expected_loss, rel=1e-6)


def test_double_and_plain_dqn_losses_differ_when_the_networks_disagree():
    batch = _cartpole_batch()
    losses = []
    for algo_class in (DQN, DoubleDQN):
        model = _model_with_fixed_batch(algo_class, batch)
        with th.no_grad():  # a target network that ranks actions opposite to the online one
            for target_param in model.q_net_target.parameters():
                target_param.mul_(-1.0)
        model.train(gradient_steps=1, batch_size=3)
        losses.append(model.logger.name_to_value["train/loss"])
    assert losses[0] != pytest.approx(losses[1])


def test_dueling_aggregation_is_value_plus_centred_advantages():
    value = th.tensor([[2.0], [-1.0]])
    advantages = th.tensor([[1.0, 2.0, 3.0], [0.0, 0.0, 6.0]])
    q = dueling_aggregate(value, advantages)
    assert th.allclose(q, th.tensor([[1.0, 2.0, 3.0], [-3.0, -3.0, 3.0]]))
    assert th.allclose(q.mean(dim=1, keepdim=True), value)


def test_dueling_network_combines_its_heads():
    model = DQN(DuelingDQNPolicy, "CartPole-v1", policy_kwargs={"net_arch": [32, 16]}, seed=0, device="cpu")
    q_net = model.q_net
    assert isinstance(q_net, DuelingQNetwork)
    obs = th.tensor(np.random.default_rng(1).normal(size=(5, 4)), dtype=th.float32)
    with th.no_grad():
        hidden = q_net.trunk(q_net.extract_features(obs, q_net.features_extractor))
        value, advantages = q_net.value_head(hidden), q_net.advantage_head(hidden)
        q = q_net(obs)
    assert value.shape == (5, 1) and advantages.shape == (5, 2)
    assert th.allclose(q, value + advantages - advantages.mean(1, keepdim=True))
    assert th.allclose(q.mean(1, keepdim=True), value, atol=1e-6)


def test_dueling_double_dqn_saves_and_loads(tmp_path):
    model = DoubleDQN(DuelingDQNPolicy, "CartPole-v1", seed=0, device="cpu")
    obs = np.random.default_rng(2).normal(size=(4, 4)).astype(np.float32)
    expected = model.q_net(th.as_tensor(obs)).detach()
    model.save(tmp_path / "model.zip")
    loaded = DoubleDQN.load(tmp_path / "model.zip", device="cpu")
    assert isinstance(loaded.q_net, DuelingQNetwork)
    assert th.allclose(loaded.q_net(th.as_tensor(obs)).detach(), expected)


def test_thesis_hyperparameters_follow_appendix_a1():
    dqn = hyperparameters("double-dqn", "E3S1")
    assert (dqn["batch_size"], dqn["buffer_size"], dqn["target_update_interval"]) == (64, 50_000, 500)
    assert (dqn["learning_rate"], dqn["exploration_final_eps"], dqn["gamma"]) == (5e-4, 0.02, 0.8)
    assert hyperparameters("dqn", "E1S1")["gamma"] == 0.9
    ppo = hyperparameters("ppo", "E4S4")
    assert (ppo["n_envs"], ppo["n_steps"], ppo["batch_size"], ppo["n_epochs"]) == (16, 125, 64, 4)
    assert (ppo["learning_rate"], ppo["gamma"], ppo["ent_coef"]) == (3e-4, 0.9, 0.1)
    a2c = hyperparameters("a2c", "E2S2")
    assert (a2c["n_envs"], a2c["n_steps"], a2c["learning_rate"], a2c["ent_coef"]) == (16, 5, 7e-4, 0.01)


def test_unknown_algorithm_or_profile_is_a_clear_error():
    with pytest.raises(InputError, match="unknown algorithm 'sac'"):
        hyperparameters("sac", "E1S1")
    with pytest.raises(InputError, match="unknown hyperparameter profile"):
        hyperparameters("ppo", "E1S1", profile="huge")
