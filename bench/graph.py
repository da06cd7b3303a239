"""Construction-graph build and query time, for the largest shared IFC file and for scaled copies of it.

    .venv/bin/python bench/graph.py [--ifc ../shared/data/ifc/AC20-FZK-Haus.ifc] [--copies 1 10 50]

Reference (measured in the same run): reading the IFC file with ``bimrobot.bim.load_model``. Every other
figure is printed in seconds and as a ratio to that reference, so runs on different machines compare.
A synthetic schedule (transport, position, assemble per element, chained) gives each element three
activities; "copies" replicate the model's elements (new GlobalIds) to show how the graph scales.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import tempfile
import time
from pathlib import Path

from bimrobot.bim import load_model
from bimrobot.bim.model import BuildingModel
from bimrobot.lbd.graph import build_graph
from bimrobot.lbd.schedule import ACTIVITY_TASK_TYPES, Activity, Schedule

SHARED_IFC = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "ifc"


def largest_shared_ifc() -> Path:
    files = sorted(SHARED_IFC.glob("*.ifc"), key=lambda p: p.stat().st_size)
    if not files:
        raise SystemExit(f"no IFC files in {SHARED_IFC}: pass --ifc FILE")
    return files[-1]


def replicate(model: BuildingModel, copies: int) -> BuildingModel:
    """``copies`` copies of the model's elements and connections, GlobalIds suffixed with the copy index."""
    if copies == 1:
        return model
    elements, connections = {}, []
    for k in range(copies):
        rename = {gid: f"{gid}_{k}" for gid in model.elements}
        for gid, element in model.elements.items():
            elements[rename[gid]] = dataclasses.replace(element, global_id=rename[gid])
        for c in model.connections:
            connections.append(
                dataclasses.replace(
                    c,
                    relating_id=rename.get(c.relating_id, c.relating_id),
                    related_id=rename.get(c.related_id, c.related_id),
                    realizing_ids=tuple(rename.get(r, r) for r in c.realizing_ids),
                )
            )
    return dataclasses.replace(model, elements=elements, connections=connections)


def synthetic_schedule(model: BuildingModel) -> Schedule:
    """Transport, position and assemble every element, one after the other (s)."""
    activities, clock = [], 0.0
    for element in model.elements.values():
        previous = None
        for kind, seconds in (("transport", 100.0), ("position", 120.0), ("assemble", 60.0)):
            activity = Activity(
                id=f"A{len(activities) + 1:06d}", name=f"{kind} {element.global_id}", activity=kind,
                global_id=element.global_id, robot=f"{kind} robot", start=clock, finish=clock + seconds,
                predecessors=(previous.id,) if previous else (), target=tuple(float(v) for v in element.position),
                storey=element.storey_id, predefined_type=ACTIVITY_TASK_TYPES[kind],
            )  # fmt: skip
            clock, previous = activity.finish, activity
            activities.append(activity)
    return Schedule(activities)


def timed(function, repeat: int = 1) -> tuple[float, object]:
    """Median wall time (s) of ``repeat`` calls, and the last result."""
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--ifc", type=Path, default=None, help="IFC file (default: the largest in ../shared/data/ifc)")
    parser.add_argument("--copies", type=int, nargs="+", default=[1, 10, 50])
    args = parser.parse_args()
    path = args.ifc or largest_shared_ifc()

    reference, model = timed(lambda: load_model(path))
    print(f"{path.name}: {len(model.elements)} elements, {len(model.connections)} connections, {len(model.storeys)} storeys")
    print(f"reference: load_model {reference:.3f} s\n")
    header = f"{'copies':>6} {'elements':>8} {'activities':>10} {'triples':>8} {'store':>8} {'build s':>8} {'x ref':>6} {'triples/s':>10} {'ready q ms':>10} {'storey q ms':>11} {'state upd ms':>12}"
    print(header)
    for copies in args.copies:
        scaled = replicate(model, copies)
        schedule = synthetic_schedule(scaled)
        storey = scaled.storeys[0].global_id if scaled.storeys else ""
        gid = next(iter(scaled.elements))
        for store in ("memory", "oxigraph"):
            with tempfile.TemporaryDirectory() as tmp:
                store_path = Path(tmp) / "store" if store == "oxigraph" else None
                build, graph = timed(lambda: build_graph(scaled, schedule, store=store, path=store_path))
                ready, _ = timed(lambda: graph.query("ready_activities"), repeat=3)
                by_storey, _ = timed(lambda: graph.query("storey_components", storeyId=storey), repeat=3)
                update, _ = timed(lambda: graph.set_component_state(gid, "InTransit"), repeat=5)
                triples = len(graph)
                graph.close()
            print(
                f"{copies:>6} {len(scaled.elements):>8} {len(schedule):>10} {triples:>8} {store:>8} {build:>8.3f} "
                f"{build / reference:>6.2f} {triples / build:>10.0f} {ready * 1e3:>10.1f} {by_storey * 1e3:>11.1f} {update * 1e3:>12.2f}"
            )


if __name__ == "__main__":
    main()
