"""One Table 6.1 from several benchmark grids: ``bimrobot rl compare GRID... -o table.md``.

Each grid is a ``bimrobot rl benchmark`` output folder; grids may differ in algorithms, seeds and env-step
budgets (a cheap algorithm can afford more seeds than an expensive one). The comparison puts every
(setting, algorithm) cell side by side in the thesis' column order, says per algorithm which grid, seeds,
budgets and command it comes from, and checks the issue's goal per setting against the thesis' best cell.
It reads only each folder's ``table.csv`` and ``grid.json``; the run dirs are not needed.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bimrobot.core.errors import InputError
from bimrobot.core.io import atomic_output_file, has_signature, signature
from bimrobot.rl.names import ALGORITHM_NAMES

SCORE_GOAL = 0.9
# The thesis' best cell per setting (Table 6.1), as normalised scores measured on the published code (issue 6).
THESIS_BEST_SCORE = {
    "E1S1": 0.99, "E1S2": 0.99, "E1S3": 0.99, "E1S4": 0.99,
    "E2S1": 0.95, "E2S2": 0.91, "E2S3": 0.98, "E2S4": 0.85,
    "E3S1": 0.65, "E3S2": 0.67, "E3S3": 0.81, "E3S4": 0.75,
    "E4S1": 0.58, "E4S2": 0.60, "E4S3": 0.64, "E4S4": 0.71,
}  # fmt: skip
SETTINGS = tuple(THESIS_BEST_SCORE)
# The thesis' column names for the algorithms it trained (its "DQN" used the double-Q target, see docs/rl.md).
THESIS_COLUMN = {"double-dqn": "DQN", "double-dueling-dqn": "DDQN", "a2c": "A2C", "ppo": "PPO"}
COLUMN_ORDER = ("double-dqn", "double-dueling-dqn", "a2c", "ppo", "maskable-ppo", "dqn", "dueling-dqn")
assert sorted(COLUMN_ORDER) == sorted(ALGORITHM_NAMES)

_INT_FIELDS = {"seeds", "timesteps", "seeds_reaching_0.9", "median_steps_to_0.9"}
_TEXT_FIELDS = {"setting", "algo"}
_REQUIRED_COLUMNS = {"setting", "algo", "seeds", "train_score", "eval_score", "seeds_reaching_0.9", "median_steps_to_0.9"}


@dataclass
class Grid:
    """One benchmark output folder: its command, its spec (``grid.json``) and its rows (``table.csv``)."""

    folder: Path
    command: str
    spec: dict[str, Any]
    rows: list[dict[str, Any]]


def _parse_value(name: str, text: str) -> Any:
    if name in _TEXT_FIELDS:
        return text
    if text == "":
        return None
    return int(float(text)) if name in _INT_FIELDS else float(text)


def read_grid(folder: str | Path) -> Grid:
    """Read a benchmark folder's ``grid.json`` and ``table.csv``; a clear error names what is missing."""
    folder = Path(folder)
    for name in ("grid.json", "table.csv"):
        if not (folder / name).is_file():
            raise InputError(f"{folder} is not a bimrobot rl benchmark folder: {name} is missing")
    try:
        grid = json.loads((folder / "grid.json").read_text())
        spec, command = grid["spec"], grid.get("command", "")
    except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError, AttributeError) as error:
        raise InputError(f"{folder / 'grid.json'} is not a benchmark grid file ({error})") from None
    if not isinstance(spec, dict) or not isinstance(spec.get("seeds"), list):
        raise InputError(f"{folder / 'grid.json'} is not a benchmark grid file: its spec has no list of seeds")
    rows = []
    with open(folder / "table.csv", newline="", encoding="utf-8", errors="replace") as handle:
        reader = csv.DictReader(handle)
        missing = _REQUIRED_COLUMNS - set(reader.fieldnames or [])
        if missing:
            raise InputError(f"{folder / 'table.csv'} is not a benchmark table: no column {', '.join(sorted(missing))}")
        for line, raw in enumerate(reader, start=2):
            try:
                rows.append({name: _parse_value(name, text) for name, text in raw.items()})
            except (TypeError, ValueError):
                raise InputError(f"{folder / 'table.csv'} line {line}: cannot read the row {raw}") from None
            if rows[-1].get("setting") not in THESIS_BEST_SCORE or rows[-1].get("algo") not in COLUMN_ORDER:
                raise InputError(f"{folder / 'table.csv'} line {line}: unknown setting or algorithm in {raw}")
    return Grid(folder, command, spec, rows)


def merge_cells(grids: list[Grid]) -> tuple[dict[tuple[str, str], dict], dict[str, Grid]]:
    """Cells by (setting, algo) and the grid each algorithm comes from; an algorithm in two grids is an error."""
    source: dict[str, Grid] = {}
    cells: dict[tuple[str, str], dict] = {}
    for grid in grids:
        for row in grid.rows:
            algo = row["algo"]
            if algo in source and source[algo] is not grid:
                raise InputError(f"algorithm {algo!r} is in both {source[algo].folder} and {grid.folder}; "
                                 "compare one grid per algorithm")
            source[algo] = grid
            cells[(row["setting"], algo)] = row
    return cells, source


def _column_title(algo: str) -> str:
    return f"{algo} (thesis \"{THESIS_COLUMN[algo]}\")" if algo in THESIS_COLUMN else algo


def _best_score(row: dict) -> float:
    """The better of the last-100 training score and the greedy evaluation score (the issue's best policy)."""
    return max(s for s in (row["train_score"], row["eval_score"], float("-inf")) if s is not None)


def _budgets(spec: dict) -> str:
    budgets = spec.get("budgets") or {}
    steps = [budgets.get(env, spec.get("timesteps")) for env in ("E1", "E2", "E3", "E4")]
    return " / ".join(f"{s / 1e3:g}k" if s and s < 1e6 else f"{s / 1e6:g}M" if s else "?" for s in steps)


def _sources_table(algos: list[str], source: dict[str, Grid]) -> list[str]:
    lines = ["| algorithm | grid | seeds | env steps per run (E1 / E2 / E3 / E4) | profile | shaping |",
             "|---|---|---|---|---|---|"]
    for algo in algos:
        spec = source[algo].spec
        shaping = f"{spec['shaping']:g} ({spec.get('shaping_metric', 'manhattan')})" if spec.get("shaping") else "none"
        lines.append(f"| {algo} | `{source[algo].folder.as_posix()}` | {len(spec['seeds'])} | {_budgets(spec)} "
                     f"| {spec.get('profile', '?')} | {shaping} |")
    return lines


def _score_table(kind: str, algos: list[str], cells: dict, source: dict[str, Grid]) -> list[str]:
    lines = ["| setting | " + " | ".join(_column_title(a) for a in algos) + " | thesis best |",
             "|---" * (len(algos) + 2) + "|"]
    for setting in SETTINGS:
        row = [cells.get((setting, a)) for a in algos]
        scores = [c[f"{kind}_score"] if c and c[f"{kind}_score"] is not None else float("-inf") for c in row]
        texts = []
        for algo, cell, cell_score in zip(algos, row, scores):
            if cell is None:
                texts.append("not run")
                continue
            text = "n/a" if cell_score == float("-inf") else f"{cell_score:.2f}"
            if cell_score == max(scores) and cell_score > float("-inf"):
                text = f"**{text}**"
            expected = len(source[algo].spec["seeds"])
            if cell["seeds"] < expected:
                text += f" [{cell['seeds']}/{expected} seeds]"
            texts.append(text)
        lines.append(f"| {setting} | " + " | ".join(texts) + f" | {THESIS_BEST_SCORE[setting]:.2f} |")
    return lines


def _steps_table(algos: list[str], cells: dict) -> list[str]:
    lines = ["| setting | " + " | ".join(algos) + " |", "|---" * (len(algos) + 1) + "|"]
    for setting in SETTINGS:
        texts = []
        for algo in algos:
            cell = cells.get((setting, algo))
            if cell is None:
                texts.append("not run")
                continue
            steps = cell.get("median_steps_to_0.9")
            texts.append(f"{steps / 1e3:.0f}k ({cell['seeds_reaching_0.9']}/{cell['seeds']})" if steps is not None
                         else f"- (0/{cell['seeds']})")
        lines.append(f"| {setting} | " + " | ".join(texts) + " |")
    return lines


def _goal_table(algos: list[str], cells: dict) -> tuple[list[str], int, int]:
    lines = ["| setting | best algorithm | score (train, last 100) | score (greedy eval) | thesis best | >= 0.9 "
             "| beats thesis |", "|---|---|---|---|---|---|---|"]
    met = beaten = 0
    for setting in SETTINGS:
        candidates = [cells[(setting, a)] for a in algos if (setting, a) in cells]
        thesis = THESIS_BEST_SCORE[setting]
        if not candidates:
            lines.append(f"| {setting} | not run | | | {thesis:.2f} | no | no |")
            continue
        best = max(candidates, key=_best_score)
        score = _best_score(best)
        met += score >= SCORE_GOAL
        beaten += score > thesis

        def num(value):
            return "n/a" if value is None else f"{value:.2f}"

        lines.append(f"| {setting} | {best['algo']} | {num(best['train_score'])} | {num(best['eval_score'])} "
                     f"| {thesis:.2f} | {'yes' if score >= SCORE_GOAL else 'no'} | {'yes' if score > thesis else 'no'} |")
    return lines, met, beaten


def comparison_markdown(grids: list[Grid]) -> str:
    """The combined table as Markdown: sources, scores (train and greedy eval), steps to 0.9, goal check."""
    cells, source = merge_cells(grids)
    algos = [a for a in COLUMN_ORDER if a in source]
    goal_lines, met, beaten = _goal_table(algos, cells)
    lines = [
        f"<!-- {signature('rl compare')} -->",
        _HEADING,
        "",
        f"Goal (issue 6): the best learned policy scores >= {SCORE_GOAL} and above the thesis' best cell. "
        f"**Met on {met} of {len(SETTINGS)} settings; above the thesis' best cell on {beaten} of {len(SETTINGS)}.**",
        "",
        "Cells: normalised score `(return - random) / (optimal - random)` of the mean over seeds (random and "
        "optimal from the exact planner's table). Best per row in bold. Each grid's own table.md has the returns "
        "with standard errors and its learning curves. Where the runs came from:",
        "",
        *_sources_table(algos, source),
        "",
        "Commands:",
        "",
        *[f"* `{grid.folder.as_posix()}`: `{grid.command}`" for grid in grids],
        "",
        "## Last 100 training episodes",
        "",
        *_score_table("train", algos, cells, source),
        "",
        "## 20 greedy evaluation episodes",
        "",
        *_score_table("eval", algos, cells, source),
        "",
        "## Median env steps until the mean of the last 100 training episodes first scored 0.9 (seeds that got there)",
        "",
        *_steps_table(algos, cells),
        "",
        "## Goal check: best algorithm per setting (better of training and greedy score)",
        "",
        *goal_lines,
        "",
    ]
    return "\n".join(lines)


_HEADING = "# Assembly-planning benchmark: all grids side by side (thesis Table 6.1)"


def is_comparison(path: Path) -> bool:
    """True for a comparison table bimrobot wrote: its signature, or the heading of one from before signatures."""
    if has_signature(path):
        return True
    try:
        with open(path, encoding="utf-8") as handle:
            return handle.readline().rstrip("\n") == _HEADING
    except (OSError, UnicodeDecodeError):
        return False


def comparison_inputs(folders: list[str | Path]) -> list[Path]:
    """The files of the grids a comparison reads or belongs beside (a grid's own summary is never its output)."""
    return [Path(folder) / name for folder in folders
            for name in ("grid.json", "table.csv", "table.md", "learning_curves.png")]


def write_comparison(folders: list[str | Path], out: str | Path) -> Path:
    """Read the grids and write the combined Markdown table to ``out`` (nothing is written on bad input)."""
    if not folders:
        raise InputError("name at least one benchmark folder to compare")
    text = comparison_markdown([read_grid(folder) for folder in folders])
    out = Path(out)
    with atomic_output_file(out, inputs=comparison_inputs(folders), recognise=is_comparison) as tmp:
        tmp.write_text(text)
    return out
