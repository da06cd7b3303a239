"""Load a trained run dir as a policy: ``load_policy(run_dir)(obs, info) -> action``.

Used by ``bimrobot assembly play --policy <run dir>`` and ``bimrobot rl eval``. The policy is greedy
(deterministic); maskable algorithms use ``info["action_mask"]``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable

import numpy as np

from bimrobot.errors import InputError
from bimrobot.rl.algorithms import get_algorithm

Policy = Callable[[np.ndarray, dict], int]


def read_config(run_dir: str | Path) -> dict[str, Any]:
    """config.json of a run dir, or an InputError saying what is missing."""
    run_dir = Path(run_dir)
    config_path = run_dir / "config.json"
    if not config_path.is_file():
        raise InputError(f"{run_dir} is not a bimrobot rl run dir: {config_path.name} is missing")
    try:
        return json.loads(config_path.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{config_path} is not valid JSON (line {exc.lineno})") from None


def load_model(run_dir: str | Path):
    """(SB3 model, config dict) of a run dir."""
    run_dir = Path(run_dir)
    config = read_config(run_dir)
    model_path = run_dir / "model.zip"
    if not model_path.is_file():
        raise InputError(f"{run_dir} has no model.zip: the run did not finish")
    algorithm = get_algorithm(config.get("algo", "?"))
    model = algorithm.sb3_class.load(model_path, device="cpu")
    return model, config


def load_policy(run_dir: str | Path) -> Policy:
    """The greedy policy of a run dir: ``policy(obs, info) -> action`` (an int in 0..5)."""
    model, config = load_model(run_dir)
    masked = get_algorithm(config["algo"]).uses_action_mask

    def policy(obs: np.ndarray, info: dict) -> int:
        kwargs = {"action_masks": info["action_mask"]} if masked and "action_mask" in info else {}
        action, _ = model.predict(obs, deterministic=True, **kwargs)
        return int(action)

    policy.setting = config["setting"]  # type: ignore[attr-defined]
    policy.algo = config["algo"]  # type: ignore[attr-defined]
    return policy
