"""Benchmark ``bimrobot convert`` against IfcOpenShell's own geometry iterator on the same file.

For every IFC file in ../shared/data/ifc (when present) and the built-in examples, in the same run:

* reference: ``ifcopenshell.geom.iterator`` over the file's elements with the same settings and kernel
  that ``bimrobot.bim`` uses (local coordinates), reading every shape's vertices and faces;
* conversion: :func:`bimrobot.world.package.convert` (read + meshes + SDF + maps + report).

Each runs in a fresh subprocess (imports done before the clock starts), so the peak memory
(``ru_maxrss``) is that run's own. Prints a markdown table; the goal is ratio <= 1.5.

    .venv/bin/python bench/convert.py                 # all files, 1 repetition (best of N with --repeat N)
    .venv/bin/python bench/convert.py --files frame.ifc other.ifc
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED_IFC = REPO.parent / "shared" / "data" / "ifc"
GOAL = 1.5


def child_iterate(path: str) -> dict:
    """Time the reference: the geometry iterator alone, as bimrobot.bim configures it."""
    import ifcopenshell
    import ifcopenshell.geom
    import ifcopenshell.util.shape

    from bimrobot.bim import reader

    start = time.perf_counter()
    ifc = ifcopenshell.open(path)
    products = reader.candidate_products(ifc, [], [])
    iterator = ifcopenshell.geom.iterator(
        reader.geometry_settings(), ifc, 2, include=products, geometry_library=reader.GEOMETRY_LIBRARY
    )
    shapes = 0
    if iterator.initialize():
        while True:
            shape = iterator.get()
            ifcopenshell.util.shape.get_vertices(shape.geometry)
            ifcopenshell.util.shape.get_faces(shape.geometry)
            shapes += 1
            if not iterator.next():
                break
    seconds = time.perf_counter() - start
    return {"seconds": seconds, "shapes": shapes, "peak_mb": _peak_mb()}


def child_convert(path: str, out: str) -> dict:
    """Time the whole conversion into a package (the same imports as the reference done first)."""
    import ifcopenshell.geom  # noqa: F401  (imported before the clock, as in child_iterate)

    from bimrobot.bim import reader  # noqa: F401
    from bimrobot.world.package import ConvertOptions, convert

    start = time.perf_counter()
    report = convert(path, out, ConvertOptions())
    seconds = time.perf_counter() - start
    return {
        "seconds": seconds,
        "elements": report["counts"]["converted"],
        "timings": report["timings_s"],
        "peak_mb": _peak_mb(),
    }


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def run_child(*args: str) -> dict:
    result = subprocess.run([sys.executable, __file__, "--child", *args], capture_output=True, text=True, check=False)
    if result.returncode != 0:
        raise RuntimeError(f"bench child {args} failed:\n{result.stderr[-2000:]}")
    return json.loads(result.stdout.strip().splitlines()[-1])


def bench_file(path: Path, repeat: int, workdir: Path) -> dict:
    best_iterate, best_convert = None, None
    for index in range(repeat):
        iterate = run_child("iterate", str(path))
        convert = run_child("convert", str(path), str(workdir / f"{path.stem}_{index}"))
        if best_iterate is None or iterate["seconds"] < best_iterate["seconds"]:
            best_iterate = iterate
        if best_convert is None or convert["seconds"] < best_convert["seconds"]:
            best_convert = convert
    return {"file": path.name, "iterate": best_iterate, "convert": best_convert}


def example_files(workdir: Path) -> list[Path]:
    from bimrobot.bim import examples

    return [examples.steel_frame(workdir / "steel-frame.ifc"), examples.greenhouse(workdir / "greenhouse.ifc")]


def table(rows: list[dict]) -> str:
    """Markdown table; "read" is bimrobot.bim.load_model, "write" the world part (meshes, SDF, maps)."""
    lines = [
        "| file | elements | iterator s | convert s | ratio | read s (/ iterator) | write s (/ iterator) "
        "| elements/s | peak MB |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        it, cv = row["iterate"], row["convert"]
        t = cv["timings"]
        ratio = cv["seconds"] / it["seconds"]
        write = t["meshes_and_mass"] + t["sdf_and_files"] + t["maps"]
        flag = "" if ratio <= GOAL else " (!)"
        lines.append(
            f"| {row['file']} | {cv['elements']} | {it['seconds']:.2f} | {cv['seconds']:.2f} | {ratio:.2f}{flag} | "
            f"{t.get('load', 0):.2f} ({t.get('load', 0) / it['seconds']:.2f}) | {write:.2f} ({write / it['seconds']:.2f}) | "
            f"{cv['elements'] / cv['seconds']:.0f} | {cv['peak_mb']:.0f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--files", nargs="*", type=Path, help="IFC files (default: shared data + examples)")
    parser.add_argument("--repeat", type=int, default=1, help="repetitions per file; the best time counts")
    parser.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        kind, *rest = args.child
        result = child_iterate(*rest) if kind == "iterate" else child_convert(*rest)
        print(json.dumps(result))
        return 0
    with tempfile.TemporaryDirectory(prefix="bimrobot-bench-") as tmp:
        workdir = Path(tmp)
        files = args.files or (sorted(SHARED_IFC.glob("*.ifc")) if SHARED_IFC.exists() else []) + example_files(workdir)
        rows = []
        for path in files:
            print(f"benchmarking {path.name} ...", file=sys.stderr, flush=True)
            rows.append(bench_file(path, args.repeat, workdir))
    print(table(rows))
    ratios = [r["convert"]["seconds"] / r["iterate"]["seconds"] for r in rows]
    total = sum(r["convert"]["seconds"] for r in rows) / sum(r["iterate"]["seconds"] for r in rows)
    print(f"\nratio over all files (sum of times): {total:.2f}; worst file: {max(ratios):.2f}; goal <= {GOAL}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
