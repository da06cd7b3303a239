"""Load a trained run dir as a policy: ``load_policy(run_dir)(obs, info) -> action``.

Used by ``bimrobot assembly play --policy <run dir>`` and ``bimrobot rl eval``. The policy is greedy
(deterministic); maskable algorithms use ``info["action_mask"]``.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Any, Callable

import numpy as np

from bimrobot.core.errors import InputError
from bimrobot.rl.algorithms import get_algorithm

Policy = Callable[[np.ndarray, dict], int]


def read_config(run_dir: str | Path) -> dict[str, Any]:
    """config.json of a run dir, or an InputError saying what is missing."""
    run_dir = Path(run_dir)
    config_path = run_dir / "config.json"
    if not config_path.is_file():
        raise InputError(f"{run_dir} is not a bimrobot rl run dir: {config_path.name} is missing")
    try:
        config = json.loads(config_path.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{config_path} is not valid JSON (line {exc.lineno})") from None
    except UnicodeDecodeError:
        raise InputError(f"{config_path} is not a text file") from None
    if not isinstance(config, dict) or not all(isinstance(config.get(key), str) for key in ("setting", "algo")):
        raise InputError(f"{config_path} is not a run's config.json: it names no setting and algorithm")
    if isinstance(config.get("seed"), bool) or not isinstance(config.get("seed"), int):
        raise InputError(f"{config_path} is not a run's config.json: it has no integer seed")
    return config


def load_model(run_dir: str | Path):
    """(SB3 model, config dict) of a run dir."""
    run_dir = Path(run_dir)
    config = read_config(run_dir)
    model_path = run_dir / "model.zip"
    if not model_path.is_file():
        raise InputError(f"{run_dir} has no model.zip: the run did not finish")
    algorithm = get_algorithm(config.get("algo", "?"))
    try:
        model = algorithm.sb3_class.load(model_path, device="cpu")
    except (zipfile.BadZipFile, ValueError, KeyError, RuntimeError, OSError, EOFError) as exc:
        raise InputError(f"{model_path} cannot be loaded as a {config['algo']} model ({type(exc).__name__}: {exc})") from None
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
