"""The DRL algorithms of the benchmark: SB3's DQN, A2C, PPO, sb3-contrib's MaskablePPO, and three small
extensions of SB3's DQN that it does not ship: Double DQN, Dueling DQN and Double + Dueling DQN.

* Double DQN (van Hasselt et al. 2016): the TD target takes the greedy next action from the *online*
  network and its value from the *target* network, ``y = r + gamma (1 - done) Q_target(s', argmax_a
  Q_online(s', a))``, instead of ``max_a Q_target(s', a)``. That is the only difference, so
  :class:`DoubleDQN` overrides :meth:`DQN.train` and nothing else.
* Dueling DQN (Wang et al. 2016): the Q network splits after a shared trunk into a state value V(s) and
  advantages A(s, a), recombined as ``Q = V + A - mean_a A`` (:func:`dueling_aggregate`).

The thesis' hyperparameters (appendix A.1) are the defaults: :func:`thesis_hyperparameters`. The thesis'
column labels were off: its "DQN" was Double DQN and its "DDQN" Double + Dueling DQN (see docs/rl.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from sb3_contrib import MaskablePPO
from stable_baselines3 import A2C, DQN, PPO
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor, create_mlp
from stable_baselines3.dqn.policies import DQNPolicy, QNetwork
from torch import nn
from torch.nn import functional as F

from bimrobot.assembly.vector import MAX_ENVS
from bimrobot.core.errors import InputError
from bimrobot.rl.names import ALGORITHM_NAMES, PROFILE_NAMES


def td_targets(
    rewards: th.Tensor,
    dones: th.Tensor,
    discounts: th.Tensor | float,
    next_q_target: th.Tensor,
    next_q_online: th.Tensor | None = None,
) -> th.Tensor:
    """One-step TD targets, shape (batch, 1).

    ``rewards``, ``dones``: (batch, 1); ``next_q_target`` and ``next_q_online``: (batch, n_actions), the
    target and online networks' Q-values of the next observations. Without ``next_q_online`` this is
    DQN's ``r + gamma (1 - done) max_a Q_target(s', a)``; with it, Double DQN's ``r + gamma (1 - done)
    Q_target(s', argmax_a Q_online(s', a))``.
    """
    if next_q_online is None:
        next_values = next_q_target.max(dim=1).values
    else:
        greedy_actions = next_q_online.argmax(dim=1, keepdim=True)
        next_values = th.gather(next_q_target, dim=1, index=greedy_actions).squeeze(1)
    return rewards + (1 - dones) * discounts * next_values.reshape(-1, 1)


class DoubleDQN(DQN):
    """SB3's DQN with the Double-DQN target (online argmax, target-network value); all else unchanged."""

    def train(self, gradient_steps: int, batch_size: int = 100) -> None:
        self.policy.set_training_mode(True)
        self._update_learning_rate(self.policy.optimizer)
        losses = []
        for _ in range(gradient_steps):
            replay_data = self.replay_buffer.sample(batch_size, env=self._vec_normalize_env)  # type: ignore[union-attr]
            discounts = replay_data.discounts if replay_data.discounts is not None else self.gamma
            with th.no_grad():
                target_q_values = td_targets(
                    replay_data.rewards,
                    replay_data.dones,
                    discounts,
                    next_q_target=self.q_net_target(replay_data.next_observations),
                    next_q_online=self.q_net(replay_data.next_observations),
                )
            current_q_values = th.gather(self.q_net(replay_data.observations), dim=1, index=replay_data.actions.long())
            loss = F.smooth_l1_loss(current_q_values, target_q_values)
            losses.append(loss.item())
            self.policy.optimizer.zero_grad()
            loss.backward()
            th.nn.utils.clip_grad_norm_(self.policy.parameters(), self.max_grad_norm)
            self.policy.optimizer.step()
        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        self.logger.record("train/loss", np.mean(losses))


def dueling_aggregate(value: th.Tensor, advantages: th.Tensor) -> th.Tensor:
    """Q(s, a) = V(s) + A(s, a) - mean_a A(s, a); ``value`` (batch, 1), ``advantages`` (batch, n_actions)."""
    return value + advantages - advantages.mean(dim=1, keepdim=True)


class DuelingQNetwork(QNetwork):
    """A Q network with a shared trunk (all of ``net_arch`` but the last layer), then a value head and an
    advantage head of ``net_arch[-1]`` units each, combined by :func:`dueling_aggregate`."""

    def __init__(
        self,
        observation_space: spaces.Space,
        action_space: spaces.Discrete,
        features_extractor: BaseFeaturesExtractor,
        features_dim: int,
        net_arch: list[int] | None = None,
        activation_fn: type[nn.Module] = nn.ReLU,
        normalize_images: bool = True,
    ) -> None:
        super().__init__(
            observation_space, action_space, features_extractor, features_dim, net_arch, activation_fn, normalize_images
        )
        del self.q_net  # replaced by the trunk and the two heads
        trunk_sizes, head_size = self.net_arch[:-1], self.net_arch[-1] if self.net_arch else 64
        trunk = create_mlp(self.features_dim, -1, trunk_sizes, activation_fn)
        trunk_out = trunk_sizes[-1] if trunk_sizes else self.features_dim
        self.trunk = nn.Sequential(*trunk)
        self.value_head = nn.Sequential(*create_mlp(trunk_out, 1, [head_size], activation_fn))
        self.advantage_head = nn.Sequential(*create_mlp(trunk_out, int(action_space.n), [head_size], activation_fn))

    def forward(self, obs: th.Tensor) -> th.Tensor:
        hidden = self.trunk(self.extract_features(obs, self.features_extractor))
        return dueling_aggregate(self.value_head(hidden), self.advantage_head(hidden))


class DuelingDQNPolicy(DQNPolicy):
    """SB3's DQN MlpPolicy with :class:`DuelingQNetwork` as online and target network."""

    def make_q_net(self) -> DuelingQNetwork:
        net_args = self._update_features_extractor(self.net_args, features_extractor=None)
        return DuelingQNetwork(**net_args).to(self.device)


@dataclass(frozen=True)
class Algorithm:
    """How to build one of the benchmark's algorithms: SB3 class, policy, and whether it uses the mask."""

    name: str
    sb3_class: type
    policy: Any
    uses_action_mask: bool = False
    off_policy: bool = False
    thesis_label: str = ""


ALGORITHMS: dict[str, Algorithm] = {
    "ppo": Algorithm("ppo", PPO, "MlpPolicy", thesis_label="PPO"),
    "maskable-ppo": Algorithm("maskable-ppo", MaskablePPO, "MlpPolicy", uses_action_mask=True),
    "a2c": Algorithm("a2c", A2C, "MlpPolicy", thesis_label="A2C"),
    "dqn": Algorithm("dqn", DQN, "MlpPolicy", off_policy=True),
    "double-dqn": Algorithm("double-dqn", DoubleDQN, "MlpPolicy", off_policy=True, thesis_label="DQN"),
    "dueling-dqn": Algorithm("dueling-dqn", DQN, DuelingDQNPolicy, off_policy=True),
    "double-dueling-dqn": Algorithm(
        "double-dueling-dqn", DoubleDQN, DuelingDQNPolicy, off_policy=True, thesis_label="DDQN"
    ),
}


def get_algorithm(name: str) -> Algorithm:
    """The :class:`Algorithm` called ``name``, or an InputError listing the known ones."""
    try:
        return ALGORITHMS[name]
    except KeyError:
        raise InputError(f"unknown algorithm {name!r}: choose one of {', '.join(ALGORITHMS)}") from None


def thesis_gamma(setting: str) -> float:
    """Discount factor of appendix A.1: 0.9 everywhere except the DQN family on Env3/Env4 (0.8)."""
    return 0.9 if setting[:2] in ("E1", "E2") else 0.8


def thesis_hyperparameters(algo: str, setting: str) -> dict[str, Any]:
    """The thesis' hyperparameters (appendix A.1) as SB3 keyword arguments, plus ``n_envs``.

    Where A.1 is silent we keep SB3's defaults (e.g. the exploration fraction 0.1 and network sizes),
    except ``learning_starts`` (1000 env steps: A.1 gives none and SB3's 100 is tiny next to a 50000 buffer).
    """
    algorithm = get_algorithm(algo)
    if algorithm.off_policy:
        return dict(
            n_envs=1,
            batch_size=64,
            buffer_size=50_000,
            target_update_interval=500,
            learning_rate=5e-4,
            exploration_initial_eps=1.0,
            exploration_final_eps=0.02,
            gamma=thesis_gamma(setting),
            learning_starts=1000,
        )
    if algo == "a2c":
        return dict(n_envs=16, n_steps=5, learning_rate=7e-4, gamma=0.9, gae_lambda=0.95, ent_coef=0.01)
    return dict(  # ppo, maskable-ppo
        n_envs=16, batch_size=64, n_steps=125, learning_rate=3e-4, gamma=0.9, gae_lambda=0.95, ent_coef=0.1, n_epochs=4
    )


def fast_hyperparameters(algo: str, setting: str) -> dict[str, Any]:
    """The thesis' hyperparameters adapted to a 2-core CPU budget: more envs per update, larger batches.

    Discounts and GAE stay as in A.1. On-policy: 64 envs x 64 steps per rollout (A2C: 64 x 5), PPO batches
    of 512 for 10 epochs at learning rate 1e-3 and entropy coefficient 0.01 (A.1: 16 x 125, batch 64, 4 epochs,
    3e-4, 0.1); measured on E1S2 with distance shaping, this reaches a score of 0.9 after ~50k env steps
    where A.1's settings had not after 100k. DQN family: 16 envs and one gradient step on a batch of 64 per
    16 env steps (A.1: one per env step), exploration over the first 20% of the run, target update every
    1000 env steps.
    """
    params = thesis_hyperparameters(algo, setting)
    algorithm = get_algorithm(algo)
    if algorithm.off_policy:
        params.update(n_envs=16, train_freq=1, gradient_steps=1, target_update_interval=1000)
        params.update(exploration_fraction=0.2, learning_starts=2000)
    elif algo == "a2c":
        params.update(n_envs=64, n_steps=5)
    else:
        params.update(n_envs=64, n_steps=64, batch_size=512, n_epochs=10, learning_rate=1e-3, ent_coef=0.01)
    return params


HYPERPARAMETER_PROFILES = {"thesis": thesis_hyperparameters, "fast": fast_hyperparameters}

assert tuple(ALGORITHMS) == ALGORITHM_NAMES and tuple(HYPERPARAMETER_PROFILES) == PROFILE_NAMES, "update rl/names.py"


def hyperparameters(algo: str, setting: str, profile: str = "thesis", overrides: dict | None = None) -> dict:
    """The hyperparameters of ``profile`` ("thesis" or "fast") for ``algo`` on ``setting``, then ``overrides``
    (checked by :func:`check_overrides`)."""
    if profile not in HYPERPARAMETER_PROFILES:
        raise InputError(f"unknown hyperparameter profile {profile!r}: choose one of {', '.join(HYPERPARAMETER_PROFILES)}")
    params = HYPERPARAMETER_PROFILES[profile](algo, setting)
    params.update(check_overrides(algo, overrides or {}))
    if not get_algorithm(algo).off_policy and params["n_envs"] * params["n_steps"] < 2:
        # SB3 asserts it (advantage normalisation over a single step divides by zero)
        raise InputError(f"{algo}: n_envs x n_steps must be at least 2, got {params['n_envs']} x {params['n_steps']}")
    return params


#: Most env steps of one run: 1e10 is centuries at the simulator's few thousand steps per second.
MAX_TIMESTEPS = 10**10

# The hyperparameters ``--set KEY=VALUE`` may change: kind ("int", "float", "bool"; "float?" also takes null)
# and the range of sensible values, inclusive (a low bound in parentheses is exclusive, as ``(0, 1]``).
# Only scalar keyword arguments of SB3's constructors are listed: the rest (policy, env, buffer classes,
# device, gSDE, which needs continuous actions) are the harness's to choose.
TUNABLE: dict[str, tuple[str, float, float, bool]] = {
    # name: (kind, low, high, low exclusive)
    "n_envs": ("int", 1, MAX_ENVS, False),
    "learning_rate": ("float", 0, 1, True),
    "n_steps": ("int", 1, 100_000, False),
    "batch_size": ("int", 2, 1_000_000, False),
    "n_epochs": ("int", 1, 1000, False),
    "gamma": ("float", 0, 1, False),
    "gae_lambda": ("float", 0, 1, False),
    "clip_range": ("float", 0, 10, True),
    "clip_range_vf": ("float?", 0, 10, True),
    "normalize_advantage": ("bool", 0, 1, False),
    "ent_coef": ("float", 0, 100, False),
    "vf_coef": ("float", 0, 100, False),
    "max_grad_norm": ("float", 0, 1e6, True),
    "target_kl": ("float?", 0, 100, True),
    "stats_window_size": ("int", 1, 1_000_000, False),
    "rms_prop_eps": ("float", 0, 1, True),
    "use_rms_prop": ("bool", 0, 1, False),
    "buffer_size": ("int", 1, 10_000_000, False),
    "learning_starts": ("int", 0, MAX_TIMESTEPS, False),
    "tau": ("float", 0, 1, True),
    "train_freq": ("int", 1, 1_000_000, False),
    "gradient_steps": ("int", -1, 10_000, False),  # -1: as many as env steps collected
    "target_update_interval": ("int", 1, MAX_TIMESTEPS, False),
    "exploration_fraction": ("float", 0, 1, False),
    "exploration_initial_eps": ("float", 0, 1, False),
    "exploration_final_eps": ("float", 0, 1, False),
}


def tunable_names(algo: str) -> list[str]:
    """The hyperparameters of ``algo`` that ``--set`` may change, sorted."""
    import inspect

    accepted = set(inspect.signature(get_algorithm(algo).sb3_class.__init__).parameters) | {"n_envs"}
    return sorted(name for name in TUNABLE if name in accepted)


def check_overrides(algo: str, overrides: dict[str, Any]) -> dict[str, Any]:
    """``overrides`` checked against ``algo``'s tunable hyperparameters and their ranges (an integral float
    such as JSON's ``1e5`` becomes an int); an unknown name or a value of the wrong kind or out of range
    is an InputError of one sentence naming the key and what is expected."""
    import math

    valid = tunable_names(algo)
    checked = {}
    for key, value in overrides.items():
        if key not in valid:
            raise InputError(f"--set {key}: unknown hyperparameter for {algo}; valid names: {', '.join(valid)}")
        kind, low, high, low_open = TUNABLE[key]
        bounds = f"{'>' if low_open else '>='} {low:g} and <= {high:g}"
        if kind == "bool":
            if not isinstance(value, bool):
                raise InputError(f"--set {key}={value!r}: {key} must be true or false")
            checked[key] = value
            continue
        if value is None and kind == "float?":
            checked[key] = None
            continue
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if kind == "int":
            if not number or (isinstance(value, float) and not value.is_integer()):
                raise InputError(f"--set {key}={value!r}: {key} must be a whole number {bounds}")
            value = int(value)
        elif not number or not math.isfinite(value):
            null = " (or null)" if kind == "float?" else ""
            raise InputError(f"--set {key}={value!r}: {key} must be a finite number {bounds}{null}")
        if value < low or value > high or (low_open and value == low):
            raise InputError(f"--set {key}={value!r}: {key} must be {bounds}")
        checked[key] = value
    return checked
