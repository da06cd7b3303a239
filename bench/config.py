"""Reading a large capability YAML: PyYAML's pure-Python loader against libyaml's parser (issue 14).

    .venv/bin/python bench/config.py                    # 2,000, 5,000 and 20,000 robots, 3 repeats
    .venv/bin/python bench/config.py --robots 1000 4000 --repeat 5

A generated RCAN capability table (the built-in one's robot types, then N robots of nine keys each,
about 250 bytes a robot) is read three ways, min/median/max seconds over ``--repeat`` runs:

- ``pure-python``: ``yaml.load`` with :data:`bimrobot.core.config.PURE_PYTHON_LOADER` (line numbers, YAML 1.2
  floats), how :func:`bimrobot.core.config.parse_yaml` read files before (without its number check);
- ``c-load``: the same ``yaml.load`` on libyaml's parser (:data:`bimrobot.core.config.LOADER`);
- ``parse_yaml``: :func:`bimrobot.core.config.parse_yaml` now (libyaml's parser, one pass that builds the
  data and checks every number).

Printed: each time, the speed-up of each against ``pure-python`` at the same size, and the growth of
``parse_yaml`` against the smallest size, measured in the same run.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from schedule import timed  # noqa: E402  (bench/schedule.py, as bench/graph.py does)


def capability_yaml(robots: int) -> str:
    """An (older-format) RCAN capability table with Table 5.2's robot types and ``robots`` generated robots."""
    from bimrobot.rcan.fleet import TABLE_5_2

    lines = ["robot_types:\n"]
    lines += [f"  {name}: {{activities: [{', '.join(sorted(kind.value for kind in kinds))}]}}\n"
              for name, kinds in TABLE_5_2.items()]
    lines.append("robots:\n")
    for i in range(robots):
        lines.append(
            f"  robot_{i:05d}:\n"
            "    types: [mobile_base, manipulator, gripper]\n"
            f"    payload_kg: {100 + i % 500}.0\n"
            "    reach_m: 6.0\n"
            "    speed_m_s: 0.8\n"
            "    arm_speed_m_s: 0.3\n"
            "    handling_s: {pick_up: 20.0, install: 45.0}\n"
            "    gripper_opening_m: [0.05, 1.5]\n"
            f"    home: [{i % 100}.0, {i // 100}.0, 0.0]\n"
        )
    return "".join(lines)


def main(argv: list[str] | None = None) -> int:
    import yaml

    from bimrobot.core import config
    from bimrobot.rcan.generation import parse_capabilities

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[2000, 5000, 20000])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    if config.LOADER is config.PURE_PYTHON_LOADER:
        print("PyYAML was built without libyaml: both loaders are the pure-Python one")
    ways = {
        "pure-python": lambda text: yaml.load(text, Loader=config.PURE_PYTHON_LOADER),  # noqa: S506
        "c-load": lambda text: yaml.load(text, Loader=config.LOADER),  # noqa: S506
        "parse_yaml": lambda text: config.parse_yaml(text, "bench"),
    }
    print(f"{'robots':>7} {'MB':>5} " + " ".join(f"{name + ' min/med/max s':>26}" for name in ways) + "  speed-up (median)")
    medians = {}
    for robots in args.robots:
        text = capability_yaml(robots)
        same = [ways[name](text) for name in ways]
        assert same[0] == same[1] == same[2], "the loaders disagree"
        assert len(parse_capabilities(same[2], "bench").robots) == robots
        row = {name: timed(lambda: way(text), args.repeat) for name, way in ways.items()}
        medians[robots] = {name: statistics.median(times) for name, times in row.items()}
        cells = " ".join(f"{min(t):8.2f} {statistics.median(t):8.2f} {max(t):8.2f}" for t in row.values())
        base = medians[robots]["pure-python"]
        speed = ", ".join(f"{name} {base / m:.1f}x" for name, m in medians[robots].items() if name != "pure-python")
        print(f"{robots:>7} {len(text) / 1e6:5.1f} {cells}  {speed}")
    smallest = min(medians)
    growth = ", ".join(f"{n / smallest:g}x robots: {medians[n]['parse_yaml'] / medians[smallest]['parse_yaml']:.2f}" for n in sorted(medians))
    print(f"parse_yaml growth against {smallest} robots: {growth}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
