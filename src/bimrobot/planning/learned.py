"""The learned planner (issue 38): MaskablePPO with a size-independent policy on ``bimrobot/Dispatch-v0``.

The policy (:class:`DispatchPolicy`, sb3-contrib's ``MaskableActorCriticPolicy`` with
:class:`DispatchExtractor`) has no parameter whose shape depends on the number of tasks or robots:

1. every node (task or floor gate) and every robot is embedded by a shared MLP of its features
   (``symlog``-scaled: seconds, metres, kg);
2. ``ROUNDS`` rounds of message passing along the precedence edges (forward and backward, mean over the
   real edges) give each task a view of what it waits for and what waits for it;
3. each (task, robot) pair is scored from the two embeddings, the pair's handling and travel times and a
   pooled context of the whole build; a learned logit from the context scores waiting. The environment's
   action mask removes everything that is not a valid award.

The padded arrays of the environment only give the batch shape, so the same weights run on any building:
at inference the padding is the building's own size.

The advised policy (the second and third shipped policies) also sees, at each decision, the next awards
of the market and of the priority rules (:data:`ADVISERS`, pair and wait features) and each ready task's
place in the market's request heap (:data:`EXTRA_NODE_FEATURES`); it learns when to follow which. The
shipped policy now reads the environment's local observation instead (``observation="local"``, not
advised): the first ready tasks of each pool and their neighbourhood, with a context of shares per kind
and state added to the pooled nodes, so its cost per decision does not grow with the building.

Training (:mod:`bimrobot.planning.learned_train`, ``bimrobot plan train``) uses generated buildings only
(real IFC models are the test set): behaviour cloning of a teacher (a warm start), then PPO fine-tuning,
with the reward divided by the market's makespan on the same building (per cent of it), so small and
large buildings weigh alike. The teacher is the pilot (:func:`pilot_demonstrations`: the market trying
the advisers' first choices where they disagree, keeping the shortest), the market, the search, or
CP-SAT (its deterministic clock). Seeded; bounded by steps, never by wall time.

The advice and the pilot live in :mod:`bimrobot.planning.learned_advice`, the training buildings and the
demonstrations in :mod:`bimrobot.planning.learned_pool` (their public names are importable from here too);
the network stays here, where saved policies name it (``bimrobot.planning.learned.DispatchPolicy``).

:class:`LearnedPlanner` plays a policy on a problem and replays its awards as a
:class:`~bimrobot.coordination.market.Dispatcher` (the contract of ``bimrobot.planning.planners``).
Times in seconds, positions in metres (site frame x, y; model frame z, z up), masses in kg.
"""

from __future__ import annotations

import contextlib
import json
import time
import warnings
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch as th
from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
from torch import nn

from bimrobot.coordination.market import Dispatcher
from bimrobot.core.errors import InputError
from bimrobot.planning.dispatch import CONTEXT, NODE_FEATURES, ROBOT_FEATURES, DispatchProblem
from bimrobot.planning.learned_advice import (ADVISERS, EXTRA_NODE_FEATURES, Advised, advice, advice_sparse, advised_space, observe,
                                              pilot_demonstrations)
from bimrobot.planning.learned_forward import LocalForward, _local_inputs
from bimrobot.planning.learned_pool import (TRAIN_SPECS, PerCentOfMarket, PoolEntry, env_for, generated_problem, imitate,
                                            imitation_accuracy, make_training_env, market_demonstrations, pilot_teacher,
                                            sizes, training_pool)
from bimrobot.planning.learned_search import AwardsReplay

#: the policy shipped with the package (``--planner learned``)
DEFAULT_POLICY = Path(__file__).parent / "policies" / "dispatch.zip"
#: the file inside a policy zip that says how it was trained (command, seed, buildings, figures)
META_NAME = "bimrobot.json"
HIDDEN = 32
ROUNDS = 2
PAIR_FEATURES = 4  # handling, travel, handling + travel (symlog s), compatible
MAX_STEPS = 10_000_000


def symlog(x: th.Tensor) -> th.Tensor:
    """sign(x) log(1 + |x|): seconds, metres and kg of any size to a few units."""
    return th.sign(x) * th.log1p(th.abs(x))


def _mlp(inputs: int, hidden: int = HIDDEN) -> nn.Sequential:
    return nn.Sequential(nn.Linear(inputs, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU())


class DispatchExtractor(nn.Module):
    """Dict observation of :class:`~bimrobot.planning.dispatch.DispatchEnv` (batched) -> per-pair logits
    (B, max_tasks x max_robots, in the action order ``task x max_robots + robot``), the wait logit (B, 1)
    and a value embedding (B, HIDDEN), concatenated. Parameters independent of the padded sizes."""

    def __init__(self, observation_space: gym.spaces.Dict, hidden: int = HIDDEN, rounds: int = ROUNDS):
        super().__init__()
        n, r = observation_space["compatibility"].shape
        self.actions = n * r + 1
        self.hidden = hidden
        self.features_dim = self.actions + hidden  # read by SB3; not a parameter shape
        self.advisers = observation_space["advice"].shape[-1] if "advice" in observation_space.spaces else 0
        extra = len(EXTRA_NODE_FEATURES) if self.advisers else 0
        self.node_in = _mlp(len(NODE_FEATURES) + extra, hidden)
        self.robot_in = _mlp(len(ROBOT_FEATURES), hidden)
        self.passes = nn.ModuleList(nn.Sequential(nn.Linear(3 * hidden, hidden), nn.ReLU()) for _ in range(rounds))
        self.pair_node = nn.Linear(hidden, hidden)
        self.pair_robot = nn.Linear(hidden, hidden, bias=False)
        self.pair_context = nn.Linear(2 * hidden, hidden, bias=False)
        self.pair_scalars = nn.Linear(PAIR_FEATURES + self.advisers, hidden, bias=False)
        self.pair_out = nn.Sequential(nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(), nn.Linear(hidden, 1))
        self.wait = nn.Sequential(nn.Linear(2 * hidden + self.advisers, hidden), nn.ReLU(), nn.Linear(hidden, 1))
        self.value = _mlp(2 * hidden, hidden)
        # the local observation's context (shares per kind and state), added to the mean node embedding
        self.context_in = nn.Linear(len(CONTEXT), hidden) if "context" in observation_space.spaces else None

    def forward(self, obs: dict) -> th.Tensor:
        h, g, context = self.embed(obs)
        advice = obs["advice"].float() if self.advisers else None
        scalars = self._scalars(obs["handling_s"].float(), obs["travel_s"].float(), obs["compatibility"].float(), advice)
        pair = (self.pair_node(h)[:, :, None, :] + self.pair_robot(g)[:, None, :, :]
                + self.pair_scalars(scalars) + self.pair_context(context)[:, None, None, :])  # (B, N, R, H)
        logits = self.pair_out(pair).flatten(1)  # (B, N * R)
        return th.cat([logits, self.wait(self._waiting(context, obs)), self.value(context)], dim=1)

    def embed(self, obs: dict) -> tuple[th.Tensor, th.Tensor, th.Tensor]:
        """(node embeddings (B, N, H) after the message passing, robot embeddings (B, R, H), the pooled
        context (B, 2H)): what every logit reads; the whole graph, O(nodes + edges)."""
        node_mask = obs["node_mask"].float()  # (B, N)
        robot_mask = obs["robot_mask"].float()  # (B, R)
        nodes = obs["node_features"]
        if self.advisers:
            nodes = th.cat([nodes, obs["order_in_kind"][..., None]], dim=-1)
        h = self.node_in(symlog(nodes)) * node_mask[..., None]  # (B, N, H)
        g = self.robot_in(symlog(obs["robot_features"])) * robot_mask[..., None]  # (B, R, H)
        routes = self._routes(obs, *h.shape[:2], h.device)
        for layer in self.passes:
            h = (h + layer(th.cat([h, *self._messages(h, routes)], dim=-1))) * node_mask[..., None]
        pooled = _mean(h, node_mask)
        if self.context_in is not None:
            pooled = pooled + self.context_in(obs["context"].float())
        return h, g, th.cat([pooled, _mean(g, robot_mask)], dim=-1)

    def pair_logits(self, h: th.Tensor, g: th.Tensor, context: th.Tensor, pairs: dict) -> th.Tensor:
        """The logits of some (task, robot) pairs of one observation (batch 1): ``pairs`` holds their
        ``node`` and ``robot`` indices (K,), ``handling_s``, ``travel_s``, ``compatibility`` (K,) and, advised,
        ``advice`` (K, advisers). Per pair the arithmetic of :meth:`forward`, on K pairs instead of all."""
        scalars = self._scalars(pairs["handling_s"], pairs["travel_s"], pairs["compatibility"], pairs.get("advice"))
        pair = (self.pair_node(h[0, pairs["node"]]) + self.pair_robot(g[0, pairs["robot"]])
                + self.pair_scalars(scalars) + self.pair_context(context))  # (K, H)
        return self.pair_out(pair)[:, 0]

    def wait_logit(self, context: th.Tensor, obs: dict) -> th.Tensor:
        """The wait logit (B, 1), as :meth:`forward`'s."""
        return self.wait(self._waiting(context, obs))

    def _waiting(self, context: th.Tensor, obs: dict) -> th.Tensor:
        return th.cat([context, obs["advice_wait"].float()], dim=-1) if self.advisers else context

    def _scalars(self, handling: th.Tensor, travel: th.Tensor, compatible: th.Tensor, advice) -> th.Tensor:
        """Per pair: handling, travel, their sum (s, symlog), compatible[, the advisers' awards]."""
        scalars = th.stack([symlog(handling), symlog(travel), symlog(handling + travel), compatible], -1)
        return th.cat([scalars, advice], dim=-1) if self.advisers else scalars

    @staticmethod
    def _routes(obs: dict, b: int, n: int, device) -> list:
        """The precedences as the message passing reads them, once per embedding: for each direction
        (predecessors, successors) the flat source and destination rows, the edge weights (1 for a real
        edge) and each node's count of real edges."""
        edges = obs["precedence"].long()  # (B, E, 2)
        weight = obs["precedence_mask"].float().reshape(-1, 1)
        offset = (th.arange(b, device=device) * n)[:, None]
        before, after = (edges[..., 0] + offset).flatten(), (edges[..., 1] + offset).flatten()
        routes = []
        for src, dst in ((before, after), (after, before)):
            count = th.zeros(b * n, 1, device=device).index_add_(0, dst, weight)
            routes.append((src, dst, weight, count.clamp(min=1.0)))
        return routes

    @staticmethod
    def _messages(h: th.Tensor, routes: list) -> tuple[th.Tensor, th.Tensor]:
        """Mean embedding of each node's predecessors and of its successors (real edges only)."""
        b, n, width = h.shape
        flat = h.reshape(b * n, width)
        out = [(th.zeros_like(flat).index_add_(0, dst, flat[src] * weight) / count).reshape(b, n, width)
               for src, dst, weight, count in routes]
        return out[0], out[1]


def _mean(x: th.Tensor, mask: th.Tensor) -> th.Tensor:
    return (x * mask[..., None]).sum(1) / mask.sum(1, keepdim=True).clamp(min=1.0)


class _Split(nn.Module):
    """Splits the extractor's output into the actor's logits and the critic's embedding."""

    def __init__(self, actions: int, hidden: int):
        super().__init__()
        self.actions, self.latent_dim_pi, self.latent_dim_vf = actions, actions, hidden

    def forward(self, features: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        return features[:, : self.actions], features[:, self.actions:]

    def forward_actor(self, features: th.Tensor) -> th.Tensor:
        return features[:, : self.actions]

    def forward_critic(self, features: th.Tensor) -> th.Tensor:
        return features[:, self.actions:]


class DispatchPolicy(MaskableActorCriticPolicy):
    """MaskableActorCriticPolicy whose logits come straight from :class:`DispatchExtractor` (no action
    layer whose shape would depend on the padded sizes); the value head reads the pooled context."""

    def __init__(self, observation_space, action_space, lr_schedule, **kwargs):
        kwargs.update(features_extractor_class=DispatchExtractor, net_arch=[], share_features_extractor=True)
        super().__init__(observation_space, action_space, lr_schedule, **kwargs)

    def _build_mlp_extractor(self) -> None:
        self.mlp_extractor = _Split(self.features_extractor.actions, self.features_extractor.hidden)

    def _build(self, lr_schedule) -> None:
        self._build_mlp_extractor()
        self.action_net = nn.Identity()
        self.value_net = nn.Linear(self.mlp_extractor.latent_dim_vf, 1)
        self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs)


# ---------------------------------------------------------------- training (the loop: learned_train.train)
def new_model(env: gym.Env, seed: int, n_steps: int = 256, batch_size: int = 64, learning_rate: float = 3e-4,
              hidden: int = HIDDEN):
    """A MaskablePPO with :class:`DispatchPolicy` of width ``hidden`` on ``env`` (one torch thread: reproducible)."""
    from sb3_contrib import MaskablePPO

    th.set_num_threads(1)
    kwargs = {"policy_kwargs": {"features_extractor_kwargs": {"hidden": hidden}}} if hidden != HIDDEN else {}
    return MaskablePPO(DispatchPolicy, env, seed=seed, n_steps=n_steps, batch_size=batch_size,
                       learning_rate=learning_rate, n_epochs=4, gamma=1.0, gae_lambda=0.95, ent_coef=0.0,
                       clip_range=0.1, device="cpu", verbose=0, **kwargs)


def policy_bytes(model, meta: dict) -> bytes:
    """``model`` as MaskablePPO's zip, with :data:`META_NAME` (how it was trained, with bimrobot's
    signature) as its first entry, uncompressed."""
    import io

    from bimrobot.core.io import signature

    buffer, out_buffer = io.BytesIO(), io.BytesIO()
    model.save(buffer)
    meta = {"bimrobot": signature("learned dispatch policy"), **meta}
    with zipfile.ZipFile(buffer) as sb3, zipfile.ZipFile(out_buffer, "w", compression=zipfile.ZIP_DEFLATED) as out:
        out.writestr(META_NAME, json.dumps(meta, indent=2, sort_keys=True) + "\n", compress_type=zipfile.ZIP_STORED)
        for item in sb3.infolist():
            out.writestr(item, sb3.read(item))
    return out_buffer.getvalue()


def save(model, path: str | Path, meta: dict) -> Path:
    """Write ``model`` with ``meta`` (:func:`policy_bytes`) to ``path`` atomically."""
    from bimrobot.core.io import atomic_output_file

    with atomic_output_file(path) as tmp:
        tmp.write_bytes(policy_bytes(model, meta))
    return Path(path)


def policy_observation(path: str | Path) -> str:
    """The observation the policy at ``path`` reads (``full`` or ``local``, from how it was trained)."""
    return read_meta(path).get("observation", "full")


def read_meta(path: str | Path) -> dict:
    """How the policy at ``path`` was trained (:data:`META_NAME`), {} when it does not say."""
    with zipfile.ZipFile(path) as archive:
        return json.loads(archive.read(META_NAME)) if META_NAME in archive.namelist() else {}


def load_policy(path: str | Path, env: gym.Env):
    """The policy saved at ``path`` rebuilt for ``env``'s padded sizes (the weights fit any size)."""
    from stable_baselines3.common.save_util import load_from_zip_file

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such policy file")
    try:
        data, params, _ = load_from_zip_file(path, device="cpu", load_data=True)
    except (zipfile.BadZipFile, ValueError, KeyError) as exc:
        raise InputError(f"{path} is not a saved policy zip ({type(exc).__name__})") from None
    if not params or "policy" not in params:
        raise InputError(f"{path} is not a saved policy zip: it holds no policy weights")
    scalars = params["policy"].get("features_extractor.pair_scalars.weight")
    advised = scalars is not None and scalars.shape[1] > PAIR_FEATURES
    wanted = "local" if "features_extractor.context_in.weight" in params["policy"] else "full"
    if wanted != getattr(env.unwrapped, "observation", "full"):
        raise InputError(f"{path} reads the {wanted} observation, this environment gives the {env.unwrapped.observation} one")
    hidden = int(params["policy"].get("features_extractor.node_in.0.weight", th.zeros(HIDDEN)).shape[0])  # its width
    policy = DispatchPolicy(advised_space(env) if advised else env.unwrapped.observation_space, env.action_space,
                            lambda _: 0.0, features_extractor_kwargs={"hidden": hidden})
    try:
        policy.load_state_dict(params["policy"])
    except RuntimeError:
        raise InputError(f"{path} holds another policy's weights, not bimrobot's dispatch policy") from None
    policy.set_training_mode(False)
    return policy


# ---------------------------------------------------------------- the planner
class LearnedPolicy:
    """``policy(env) -> action``: the greedy masked choice of a loaded policy on a :class:`DispatchEnv`,
    the valid action of the highest logit (the first in action order on a tie), as sb3-contrib's
    deterministic action. ``fast`` (default): the embedding runs over the whole graph, the pair scores
    only for the valid awards, and a decision with one valid action takes it without the network;
    False: sb3-contrib's masked distribution over every (task, robot) pair (tests compare the two). With
    the local observation the embedding runs over the observed nodes only and the candidates are the
    observed ready tasks' awards (``local_actions``). ``timed``: ``cpu`` adds up this process's CPU
    seconds in the observation, the advice and the network over its ``decisions``, of which ``forced``
    had one valid action (off by default: each clock read costs time). ``numpy`` (default): a local,
    unadvised policy is scored by :class:`~bimrobot.planning.learned_forward.LocalForward` (the same
    arithmetic without torch's module calls); False: by the torch modules."""

    def __init__(self, policy, fast: bool = True, timed: bool = False, numpy: bool = True):
        self.policy = policy
        self.fast = fast
        extractor = policy.features_extractor
        local = extractor.context_in is not None and not extractor.advisers
        self.forward = LocalForward(extractor) if fast and numpy and local else None  # torch's arithmetic in numpy
        self._clock = time.process_time if timed else float  # float() is 0.0; a CPU clock read cost 0.6 ms on a busy VM
        self.cpu = {"observation": 0.0, "advice": 0.0, "network": 0.0}
        self.decisions = self.forced = 0
        self._edges: tuple = (None, None)

    def __call__(self, env: gym.Env) -> int:
        env = env.unwrapped
        self.decisions += 1
        return self._fast(env) if self.fast else self._full(env)

    def _full(self, env) -> int:
        advised = bool(self.policy.features_extractor.advisers)
        with _writable_ignored():
            obs = {k: th.as_tensor(v[None]).float() for k, v in observe(env, advised).items()}
        with th.no_grad():
            action = self.policy.get_distribution(obs, action_masks=env.action_masks()[None]).get_actions(deterministic=True)
        return int(action[0])

    def _fast(self, env) -> int:
        actions = _candidates(env)
        if len(actions) == 1:
            self.forced += 1
            return actions[0]
        return actions[int(th.argmax(self._logits(env, actions)))]

    def ranked(self, env: gym.Env, advised: tuple | None = None) -> list[int]:
        """The valid actions, highest logit first (action order among equal logits): the greedy choice
        first. ``advised``: :func:`advice_sparse`'s result at this decision, when the caller has it."""
        env = env.unwrapped
        actions = _candidates(env)
        if len(actions) == 1:
            return actions
        order = th.argsort(-self._logits(env, actions, advised), stable=True)
        return [actions[int(i)] for i in order]

    def _logits(self, env, actions: list[int], advised: tuple | None = None) -> th.Tensor:
        """The logits of the valid ``actions`` (waiting last where valid): the graph embedded once, the
        pairs scored only for the valid awards."""
        start = self._clock()
        views = env._observation()
        if self.forward is not None and env._local is not None:
            return self._numpy_logits(env, actions, views, start)
        obs, rows = self._tensors(env, views) if env._local is None else _local_tensors(env, views)
        extractor = self.policy.features_extractor
        nodes, robots = _awards(env, actions)
        pairs = {"node": th.from_numpy(rows[nodes] if rows is not None else nodes), "robot": th.from_numpy(robots),
                 **{k: th.from_numpy(np.ascontiguousarray(views[k][nodes, robots])).float()
                    for k in ("handling_s", "travel_s", "compatibility")}}
        advised_at = self._clock()
        if extractor.advisers:
            awarded, wait, order = advised if advised is not None else advice_sparse(env)
            obs.update(advice_wait=th.from_numpy(wait)[None], order_in_kind=th.from_numpy(order)[None])
            empty = np.zeros(len(ADVISERS), np.float32)
            pairs["advice"] = th.from_numpy(np.array([awarded.get(p, empty) for p in zip(nodes.tolist(), robots.tolist())],
                                                     np.float32).reshape(len(nodes), len(ADVISERS)))
        network = self._clock()
        with th.inference_mode():
            h, g, context = extractor.embed(obs)
            logits = extractor.pair_logits(h, g, context, pairs)
            if actions[-1] == env.wait_action:
                logits = th.cat([logits, extractor.wait_logit(context, obs)[0]])
        self.cpu["observation"] += advised_at - start
        self.cpu["advice"] += network - advised_at
        self.cpu["network"] += self._clock() - network
        return logits

    def _numpy_logits(self, env, actions: list[int], views: dict, start: float) -> th.Tensor:
        """:meth:`_logits` of a local policy by :class:`~bimrobot.planning.learned_forward.LocalForward`."""
        inputs, rows = self.forward.inputs(env, views)
        nodes, robots = _awards(env, actions)
        pairs = [views[k][nodes, robots] for k in ("handling_s", "travel_s", "compatibility")]
        network = self._clock()
        h, g, context = self.forward.embed(self.forward.node_embeddings(env, env._local.nodes), *inputs[1:])
        logits = self.forward.pair_logits(h, g, context, rows[nodes], robots, *pairs)
        if actions[-1] == env.wait_action:
            logits = np.append(logits, np.float32(self.forward.wait_logit(context)))
        self.cpu["observation"] += network - start
        self.cpu["network"] += self._clock() - network
        return th.from_numpy(logits)

    def _tensors(self, env, views: dict) -> dict:
        """The embedding's inputs (batch 1) as float tensors, read from the environment's arrays without a
        copy where they are float32; the precedences once per episode."""
        with _writable_ignored():
            if self._edges[0] != (id(env), env._episode):
                self._edges = ((id(env), env._episode), th.as_tensor(views["precedence"][None]).long(),
                               th.as_tensor(views["precedence_mask"][None]).float())
            obs = {k: th.as_tensor(views[k][None]).float() for k in ("node_features", "node_mask", "robot_features", "robot_mask")}
        return {**obs, "precedence": self._edges[1], "precedence_mask": self._edges[2]}, None


def _candidates(env) -> list[int]:
    """The actions a policy chooses among: every valid one, or with the local observation those of the
    observed ready tasks (:meth:`~bimrobot.planning.dispatch.DispatchEnv.local_actions`)."""
    return env.valid_actions() if env._local is None else env.local_actions()


def _awards(env, actions: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The graph nodes and robot indices of the awards among valid ``actions`` (waiting, last where valid, left out)."""
    awards = actions[: len(actions) - (actions[-1] == env.wait_action)]
    return np.divmod(np.array(awards, np.int64), env.max_robots)


def _local_tensors(env, views: dict) -> tuple[dict, np.ndarray]:
    """:func:`_local_inputs` as the extractor's batch of one (tensors; every node and edge real): the same
    embeddings and logits as the padded arrays (masks)."""
    (features, pairs, robots, robot_mask, context), where = _local_inputs(env, views)
    with _writable_ignored():
        obs = {"node_features": th.from_numpy(features)[None], "node_mask": th.ones(1, len(features)),
               "robot_features": th.as_tensor(robots[None]), "robot_mask": th.as_tensor(robot_mask[None]).float(),
               "precedence": th.from_numpy(pairs)[None], "precedence_mask": th.ones(1, len(pairs)),
               "context": th.as_tensor(context[None])}
    return obs, where


@contextlib.contextmanager
def _writable_ignored():
    """Silences torch's warning on a read-only numpy array (the environment's views; never written)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "The given NumPy array is not writable")
        yield


class LearnedPlanner:
    """A learned policy as a planner: ``dispatcher(problem)`` plans ``problem`` (padded to its own size)
    and returns a :class:`~bimrobot.coordination.market.Dispatcher` that replays the plan's awards at the
    same times, so ``simulate`` with it gives the planned schedule. ``path`` None: the shipped
    :data:`DEFAULT_POLICY`. The environment gives the observation the policy reads (its ``bimrobot.json``).

    ``search`` (rollouts, default :data:`~bimrobot.planning.learned_search.DEFAULT_BUDGET`): the policy
    proposes and rollouts decide (:func:`bimrobot.planning.learned_search.search`): the plan starts from
    the shortest of the portfolio's schedules and the policy's greedy one, so it is never longer than the
    portfolio's nor the market's. ``search=0``: the policy plays alone, greedily; then ``guard`` (default
    True), the "never worse" rule, also plays the least-cost market on the same problem in the same event
    simulation and replays whichever schedule is shorter (the policy's on a tie). ``last`` says, after
    each ``dispatcher`` call, the makespans (s) and which plan won; with the search, the budget and the
    rollouts used too."""

    def __init__(self, path: str | Path | None = None, guard: bool = True, search: int | None = None):
        from bimrobot.planning.learned_search import DEFAULT_BUDGET

        self.path = Path(path) if path is not None else DEFAULT_POLICY
        if not self.path.is_file():
            raise InputError(f"{self.path}: no such policy file" + (" (no learned policy ships with this version)" if path is None else ""))
        self.meta = read_meta(self.path)
        self.observation = self.meta.get("observation", "full")  # what the policy reads
        self.guard = guard
        self.search = DEFAULT_BUDGET if search is None else int(search)
        if self.search < 0:
            raise InputError(f"the learned planner's search budget must be 0 or more rollouts, got {self.search}")
        self.last: dict = {}

    def play(self, problem: DispatchProblem, policy=None):
        """(the awards [(time s, task key, robot)], the simulation result) of the loaded policy (or of
        ``policy(env) -> action``, e.g. :class:`~bimrobot.planning.dispatch.MarketPolicy`) on ``problem``."""
        env = env_for(problem, copy_observation=False, observation=self.observation)  # the policy reads each observation once
        policy = policy or LearnedPolicy(load_policy(self.path, env))
        env.reset(seed=0)
        awards, done, truncated = [], False, False
        while not (done or truncated):
            action = policy(env)
            if action != env.wait_action and env._valid(action):
                node, robot = divmod(action, env.max_robots)
                awards.append((float(env.sim.build.env.now), env.graph.keys[node], env.robot_names[robot]))
            _, _, done, truncated, _ = env.step(action)
        return awards, env.result

    def dispatcher(self, problem: DispatchProblem) -> Dispatcher:
        if self.search:
            return self._searched(problem)
        awards, result = self.play(problem)
        self.last = {"policy_s": float(result.makespan), "market_s": None, "chosen": "policy"}
        if self.guard:
            from bimrobot.planning.dispatch import MarketPolicy

            market_awards, market = self.play(problem, MarketPolicy())
            self.last["market_s"] = float(market.makespan)
            if market.makespan < result.makespan - 1e-9:
                awards, self.last["chosen"] = market_awards, "market"
        return ReplayDispatcher(awards)

    def _searched(self, problem: DispatchProblem) -> Dispatcher:
        """The policy with decision-time search (:func:`bimrobot.planning.learned_search.search`)."""
        from bimrobot.planning.learned_search import search

        env = env_for(problem, copy_observation=False, observation=self.observation)
        self.player = LearnedPolicy(load_policy(self.path, env))
        found = search(problem, self.player, self.search, env=env)
        self.last = {**found.notes(), "policy_s": found.policy_s, "chosen": "search"}
        return ReplayDispatcher(found.awards)


class ReplayDispatcher(AwardsReplay):
    """Replays the learned planner's recorded awards (:class:`~bimrobot.planning.learned_search.AwardsReplay`)."""

    name = "learned"


__all__ = ["DEFAULT_POLICY", "DispatchExtractor", "LearnedPlanner", "LearnedPolicy", "ReplayDispatcher", "new_model",
           "save", "load_policy", "read_meta", "imitate", "imitation_accuracy", "market_demonstrations",
           "training_pool", "generated_problem", "env_for", "ADVISERS", "Advised", "advice", "observe",
           "pilot_demonstrations", "pilot_teacher", "TRAIN_SPECS", "PoolEntry",
           "PerCentOfMarket", "make_training_env", "sizes", "EXTRA_NODE_FEATURES", "advised_space"]
