"""MuJoCo physics speed: real-time factor of the thesis' experiment 1 on the ``mujoco`` RCAN backend,
and steps per second of the bare scenes, each as a ratio against a reference measured in the same run.

- ``experiment 1``: simulated seconds / wall seconds of its five activities (Husky + UR5: drive,
  inverse kinematics, torque-controlled arm, weld grasp, placement check), the backend built outside
  the clock; reference: the bare robot scene (the capability table's robots, controllers running,
  nothing to do) stepped for the same simulated time.
- ``bare robot scene``: steps/s of that scene with its controllers (Python, every step).
- ``steel-frame yard``: steps/s of ``convert --target mujoco --layout yard`` of the chapter-4 frame
  (24 free components on CoACD pieces, bolts left out), plain ``mj_step``.
- reference for both: steps/s of a one-box scene (ground and one free box at rest) in the same run.
- ``--frame``: real-time factor of the chapter-4 steel frame's schedule (``bimrobot build --fleet
  fleet2``, 160 activities, six heavy-variant robots) run by RCAN on the mujoco backend, as a ratio
  of experiment 1's in the same repeat (minutes per repeat).

min/median/max over ``--repeats`` (default 3). ``--pictures DIR`` also writes the docs' pictures of
experiment 1 (pick-up and install; needs MUJOCO_GL=osmesa or egl). Usage:
``MUJOCO_GL=osmesa .venv/bin/python bench/physics.py [--repeats 3] [--pictures docs/img]``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

ONE_BOX = """<mujoco><option timestep="0.002"/><worldbody><geom type="plane" size="10 10 .1"/>
<body pos="0 0 0.1"><freejoint/><geom type="box" size=".1 .1 .1" mass="10"/></body></worldbody></mujoco>"""


def steps_per_second(model, data, steps: int = 5000) -> float:
    import mujoco

    started = time.perf_counter()
    mujoco.mj_step(model, data, nstep=steps)
    return steps / (time.perf_counter() - started)


def reference() -> float:
    import mujoco

    model = mujoco.MjModel.from_xml_string(ONE_BOX)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=500)  # at rest
    return steps_per_second(model, data)


def yard_scene(folder: Path):
    import mujoco

    from bimrobot.bim import load_model
    from bimrobot.bim.examples import steel_frame
    from bimrobot.export.gazebo.package import ConvertOptions, build_package

    model_in = load_model(steel_frame(folder / "frame.ifc"), exclude="IfcMechanicalFastener")
    build_package(model_in, folder / "yard", ConvertOptions(target="mujoco", layout="yard", maps=False))
    model = mujoco.MjModel.from_xml_path(str(folder / "yard" / "mujoco" / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=1500)  # settled (3 s)
    return model, data


def experiment_one(pictures: Path | None = None) -> tuple[float, float, float]:
    """(simulated s, wall s, bare-scene wall s for the same simulated time) of experiment 1."""
    from bimrobot.rcan.backends.mujoco import MujocoBackend
    from bimrobot.rcan.generation import load_capabilities
    from bimrobot.rcan.node import RcanNode
    from bimrobot.rcan.plans import experiment

    backend = MujocoBackend(load_capabilities())
    nodes = [RcanNode(f"rcan/{a.activity_id}", a, "husky_ur5", "mujoco") for a in experiment(1).activities]
    started = time.perf_counter()
    for node in nodes:
        result = backend.execute(node)
        if not result.success:
            raise SystemExit(f"experiment 1 failed: {result.message}")
        if pictures is not None and node.kind.value in ("pick_up", "position_for_installing"):
            _picture(backend, pictures / ("physics-pick-up.png" if node.kind.value == "pick_up" else "physics-install.png"))
    wall = time.perf_counter() - started
    simulated = backend.site.time_s
    bare = MujocoBackend(load_capabilities())
    started = time.perf_counter()
    bare.site.step(simulated)
    return simulated, wall, time.perf_counter() - started


def frame_schedule(folder: Path) -> tuple[float, float, int, int]:
    """(simulated s, wall s, activities done, activities) of the chapter-4 steel frame's schedule
    (``bimrobot build --fleet fleet2``) run by RCAN on the mujoco backend; the build outside the clock."""
    from bimrobot.bim.examples import steel_frame
    from bimrobot.cli import main as bimrobot
    from bimrobot.lbd.graph import ConstructionGraph
    from bimrobot.rcan.generation import load_capabilities
    from bimrobot.rcan.plans import plan_from_graph
    from bimrobot.rcan.system import run_plan

    graph_path = folder / "frame-build" / "graph.ttl"
    if not graph_path.exists():
        if bimrobot(["build", str(steel_frame(folder / "frame-schedule.ifc")), "--fleet", "fleet2",
                     "-o", str(folder / "frame-build")]) not in (0, 1):
            raise SystemExit("bimrobot build of the steel frame failed")
    activities = plan_from_graph(ConstructionGraph.open(str(graph_path)), (-10.0, -10.0, 0.0), standoff_m=0.6)
    started = time.perf_counter()
    report = run_plan(activities, load_capabilities("fleet2"), backend="mujoco")
    wall = time.perf_counter() - started
    return report.backend_summary["simulated_s"], wall, len(report.done), len(activities)


def _picture(backend, path: Path) -> None:
    from bimrobot.physics.render import render_png

    site = backend.site
    x, y, yaw = site.base_xy_yaw("husky_ur5")
    render_png(site.model, site.data, path, lookat=(x, y, 0.4), distance=2.6, azimuth=float(yaw * 57.3 + 120),
               elevation=-25)
    print(f"wrote {path}")


def spread(values: list[float]) -> str:
    return f"{min(values):.3g}/{statistics.median(values):.3g}/{max(values):.3g}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--pictures", type=Path, help="write the docs' pictures of experiment 1 here")
    parser.add_argument("--frame", action="store_true",
                        help="also the chapter-4 frame's schedule on the mujoco backend (minutes per repeat)")
    args = parser.parse_args(argv)
    rows: dict[str, list[float]] = {k: [] for k in ("ref", "rtf", "rtf_ratio", "bare", "bare_ratio", "yard", "yard_ratio")}
    with tempfile.TemporaryDirectory() as folder:
        yard_model, yard_data = yard_scene(Path(folder))
        for repeat in range(args.repeats):
            ref = reference()
            simulated, wall, bare_wall = experiment_one(args.pictures if repeat == 0 else None)
            yard = steps_per_second(yard_model, yard_data, 2000)
            bare_steps = simulated / 0.002 / bare_wall
            rows["ref"].append(ref)
            rows["rtf"].append(simulated / wall)
            rows["rtf_ratio"].append(bare_wall / wall)  # experiment's speed relative to the idle scene's
            rows["bare"].append(bare_steps)
            rows["bare_ratio"].append(bare_steps / ref)
            rows["yard"].append(yard)
            rows["yard_ratio"].append(yard / ref)
            if args.frame:
                frame_sim, frame_wall, done, total = frame_schedule(Path(folder))
                rows.setdefault("frame", []).append(frame_sim / frame_wall)
                rows.setdefault("frame_ratio", []).append((frame_sim / frame_wall) / (simulated / wall))
                print(f"repeat {repeat + 1}: steel-frame schedule {frame_sim:.0f} s simulated in {frame_wall:.1f} s, "
                      f"{done}/{total} activities done", flush=True)
            print(f"repeat {repeat + 1}: experiment 1 {simulated:.1f} s simulated in {wall:.2f} s (real-time factor "
                  f"{simulated / wall:.1f}); bare robot scene {bare_steps:.0f} steps/s; steel-frame yard {yard:.0f} "
                  f"steps/s; one-box reference {ref:.0f} steps/s", flush=True)
    print("\nmin/median/max over", args.repeats, "repeats")
    print(f"  one-box reference:                 {spread(rows['ref'])} steps/s")
    print(f"  experiment 1 real-time factor:     {spread(rows['rtf'])} (x real time)")
    print(f"  experiment 1 / bare robot scene:   {spread(rows['rtf_ratio'])} (wall time of the idle scene / of the experiment)")
    print(f"  bare robot scene:                  {spread(rows['bare'])} steps/s = {spread(rows['bare_ratio'])} x reference")
    print(f"  steel-frame yard (24 free bodies): {spread(rows['yard'])} steps/s = {spread(rows['yard_ratio'])} x reference")
    if args.frame:
        print(f"  steel-frame schedule real-time factor: {spread(rows['frame'])} (x real time) = "
              f"{spread(rows['frame_ratio'])} x experiment 1's")
    return 0


if __name__ == "__main__":
    sys.exit(main())
