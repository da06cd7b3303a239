"""DRL assembly-planning benchmark: 16 Gymnasium environments, a batched simulator and an exact planner.

``import bimrobot.assembly`` registers ``bimrobot/Assembly-E{1..4}S{1..4}-v0``, one per file of
``assembly/settings`` (time limits from the files: 100, 100, 300, 600 steps for E1-E4, through
Gymnasium's TimeLimit). See ``docs/assembly.md``.
"""

from __future__ import annotations

import gymnasium as gym

from bimrobot.assembly.env import AssemblyEnv
from bimrobot.assembly.scenario import SETTINGS, Scenario, benchmark_scenario, load_scenario, setting_time_limit

__all__ = ["SETTINGS", "AssemblyEnv", "Scenario", "benchmark_scenario", "load_scenario", "make_env", "env_id"]


def env_id(setting: str) -> str:
    """Gymnasium id of a benchmark setting: ``env_id("E2S2") == "bimrobot/Assembly-E2S2-v0"``."""
    return f"bimrobot/Assembly-{setting}-v0"


def make_env(setting: str, **kwargs) -> gym.Env:
    """``gym.make`` of a benchmark setting ("E1S1" .. "E4S4"), with its time limit; kwargs go to AssemblyEnv."""
    benchmark_scenario(setting)  # a clear error for unknown settings
    return gym.make(env_id(setting), **kwargs)


def _register() -> None:
    for setting in SETTINGS:
        if env_id(setting) in gym.registry:
            continue
        gym.register(
            id=env_id(setting),
            entry_point="bimrobot.assembly.env:AssemblyEnv",
            vector_entry_point="bimrobot.assembly.vector:AssemblyVectorEnv",
            max_episode_steps=setting_time_limit(setting),  # the setting file's time_limit
            kwargs={"setting": setting},
        )


_register()
