"""Training the learned planner (issue 38): imitation of a teacher on generated buildings, then PPO.

:func:`train` (``bimrobot plan train``) draws the training buildings (:mod:`bimrobot.planning.learned_pool`,
real IFC models are the test set), labels a teacher's decisions on them, clones them into a new
:class:`~bimrobot.planning.learned.DispatchPolicy` and fine-tunes it with MaskablePPO. The teachers
(:data:`TEACHERS`): the pilot, the least-cost market, the search without a policy, and CP-SAT
(:func:`cpsat_teacher`). This module sits above the planner registry (:mod:`bimrobot.planning.planners`,
which runs the learned planner): the CP-SAT teacher asks the registry for CP-SAT's plan.

Seeded; bounded by steps and by CP-SAT's deterministic clock, never by wall time. Times in seconds.
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass

import numpy as np
import torch as th

from bimrobot.core.errors import InputError
from bimrobot.planning.dispatch import DispatchEnv
from bimrobot.planning.learned import ADVISERS, HIDDEN, MAX_STEPS, ROUNDS, new_model
from bimrobot.planning.learned_pool import (TRAIN_SPECS, PoolEntry, _pad, _stack, imitate, make_training_env,
                                            market_demonstrations, pilot_teacher, play_demonstrations, training_pool)

#: CP-SAT as a teacher: deterministic seconds per solve (CP-SAT's own work clock, one worker), so the same
#: pool gives the same schedules on any machine; the wall-clock limit is only a guard that never binds
#: here (the eight training buildings of seed 0: 4-28 CPU s each at 5 units).
CPSAT_TEACHER_UNITS = 5.0
CPSAT_TEACHER_GUARD_S = 3600.0


def cpsat_teacher(pool: list[PoolEntry], pad: tuple[int, int, int], observation: str = "full",
                  units: float = CPSAT_TEACHER_UNITS) -> tuple[tuple[dict, np.ndarray, np.ndarray], dict]:
    """CP-SAT's schedule of each training building (a per-joint pool: CP-SAT's tasks), started from the
    portfolio's shortest and solved for ``units`` deterministic seconds per solve, played in the
    environment padded to ``pad``: its decisions as demonstrations (observations stacked per key, masks,
    actions; advised with the full observation), and {spec: CP-SAT's executed makespan (s)}."""
    from bimrobot.planning.learned_advice import PlannerPolicy
    from bimrobot.planning.planners import dispatcher_for

    observations, masks, actions, makespans = [], [], [], {}
    for entry in pool:
        replay = dispatcher_for("cp-sat", entry.problem, deterministic_s=units, time_limit_s=CPSAT_TEACHER_GUARD_S)
        policy = PlannerPolicy("cp-sat", make=lambda replay=replay: replay)  # one episode: one plan
        env = DispatchEnv(entry.problem, max_tasks=pad[0], max_robots=pad[1], max_edges=pad[2], observation=observation)
        play_demonstrations(env, policy, observation == "full", observations, masks, actions)
        makespans[entry.spec] = round(float(env.result.makespan), 3)
    return _stack(observations, masks, actions), makespans


@dataclass
class TrainResult:
    """What :func:`train` did: the model, the imitation accuracy (0-1), the pool's specs and market makespans."""

    model: object
    accuracy: float | None
    pool: list[PoolEntry]
    meta: dict


#: the teachers :func:`train` imitates: the pilot (:func:`~bimrobot.planning.learned_advice.pilot_demonstrations`,
#: advised policy), the least-cost market (the first policy's teacher, no advice), the search without a
#: policy (the ``rollout`` planner, :func:`bimrobot.planning.learned_search.search_teacher`, advised), or
#: CP-SAT (:func:`cpsat_teacher`, on the buildings per joint)
TEACHERS = ("pilot", "market", "search", "cp-sat")


def train_command(seed: int, steps: int, imitation_steps: int, teacher: str = "pilot", observation: str = "full",
                  hidden: int = HIDDEN, output: str = "OUT") -> str:
    """The ``bimrobot plan train`` command line that trains with these arguments (defaults left out), as
    train.json and the policy's metadata record it."""
    return shlex.join(["bimrobot", "plan", "train", "--seed", str(seed), "--steps", str(steps),
                       "--imitation-steps", str(imitation_steps),
                       *(["--teacher", teacher] if teacher != "pilot" else []),
                       *(["--observation", observation] if observation != "full" else []),
                       *(["--hidden", str(hidden)] if hidden != HIDDEN else []), "-o", output])


def train(seed: int, steps: int, imitation_steps: int = 400, specs=TRAIN_SPECS, command: str | None = None,
          on_imitated=None, teacher: str = "pilot", observation: str = "full", hidden: int = HIDDEN) -> TrainResult:
    """Train a policy on generated buildings: imitation of ``teacher`` (``imitation_steps``, 0 for none),
    then ``steps`` PPO env steps (0 for none). ``on_imitated(model, accuracy)`` is called between the two.
    ``hidden``: the network's width (:data:`HIDDEN` by default; its cost per decision grows with its square).
    The pilot's and the search's policies are advised (:data:`ADVISERS`) on the full observation; the
    market's is not, nor any on the local one (``observation="local"``: the ready tasks' neighbourhood,
    teacher search or market). Seeded: the same arguments give the same weights."""
    if teacher not in TEACHERS:
        raise InputError(f"unknown teacher {teacher!r}: choose one of {', '.join(TEACHERS)}")
    if observation == "local" and teacher == "pilot":
        raise InputError("the pilot teacher labels advised observations: with --observation local choose --teacher search or market")
    if not 0 <= steps <= MAX_STEPS:
        raise InputError(f"--steps must be from 0 to {MAX_STEPS:,} env steps, got {steps}")
    if not 0 <= imitation_steps <= MAX_STEPS:
        raise InputError(f"--imitation-steps must be from 0 to {MAX_STEPS:,}, got {imitation_steps}")
    if seed < 0:
        raise InputError(f"--seed must be a whole number >= 0, got {seed}")
    if not 1 <= hidden <= 1024:
        raise InputError(f"--hidden must be a width from 1 to 1024, got {hidden}")
    th.manual_seed(seed)
    pool = training_pool(seed, specs, per_joint=teacher == "cp-sat")
    advised = teacher != "market" and observation == "full"
    env = make_training_env(pool, seed, advised, observation)
    model = new_model(env, seed, hidden=hidden)
    accuracy, taught = None, {}
    if imitation_steps:
        if teacher == "search":
            from bimrobot.planning.learned_search import search_teacher

            demonstrations, taught = search_teacher(pool, _pad(pool), observation=observation)
        elif teacher == "cp-sat":
            demonstrations, taught = cpsat_teacher(pool, _pad(pool), observation=observation)
        elif advised:
            demonstrations, taught = pilot_teacher(pool, _pad(pool))
        else:
            demonstrations = market_demonstrations(pool, _pad(pool), observation=observation)
        accuracy = imitate(model.policy, demonstrations, imitation_steps, seed)
        if on_imitated is not None:
            on_imitated(model, accuracy)
    if steps:
        model.learn(total_timesteps=steps)
    meta = {
        "command": command or train_command(seed, steps, imitation_steps, teacher, observation, hidden),
        "seed": seed, "steps": steps, "imitation_steps": imitation_steps,
        "imitation_accuracy": accuracy, "hidden": hidden, "rounds": ROUNDS, "teacher": teacher, "observation": observation,
        "advisers": list(ADVISERS) if advised else [],
        "training_buildings": {p.spec: round(p.market_s, 3) for p in pool},
        "teacher_makespans_s": taught,
        "note": "trained on generated buildings only; real IFC models are the test set",
    }
    return TrainResult(model, accuracy, pool, meta)


__all__ = ["TEACHERS", "TrainResult", "train", "train_command", "cpsat_teacher", "CPSAT_TEACHER_UNITS"]
