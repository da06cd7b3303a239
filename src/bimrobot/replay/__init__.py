"""4D replay of a simulated build in Rerun (``bimrobot replay``).

:func:`write_replay` turns a `bimrobot build` output folder (or a `simulate` + `convert` pair) into a
Rerun recording: the building element by element, the components moving from the yard with their
transport robots into place, coloured by the thesis' states, the robots with their activities, a
Gantt chart you can scrub and the counts of components per state. Open it with ``rerun build.rrd``
(native viewer) or ``bimrobot replay out/ --serve`` (web viewer on 127.0.0.1). The build's RCAN run
(``rcan/``), or an `rcan run` folder given alone, adds what RCAN executed and, from the mujoco backend,
the recorded body trajectories (:mod:`bimrobot.replay.record_rcan`). See docs/replay.md.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path


def write_replay(out_dir, rrd_path, *, model=None, start: dt.datetime | None = None,
                 simulation=None, building=None, draw: str = "auto") -> dict:
    """Write the replay of the build in ``out_dir`` to ``rrd_path`` (through bimrobot.core.io's output policy).

    ``out_dir``: a `bimrobot build` output folder, a `convert` package folder when ``simulation``
    (the `simulate` output folder) is given, or an `rcan run` folder (report.json, state database,
    trajectory CSV; ``model`` then names the IFC file). ``model``: the IFC file when it moved since the build.
    ``start``: calendar date-time of the build's second 0 (adds a ``calendar`` timeline).
    ``building``: the BuildingModel of the build's IFC file, already read (``bimrobot build`` reads it once
    for every stage); None reads the file.
    ``draw``: the building as "meshes" (each element's own, lightened), "boxes" (each component's box,
    grouped by state: few entities, a large model opens sooner in the web viewer) or "auto" (boxes for
    a large model, :func:`bimrobot.replay.compact.is_large`).
    Returns a summary: pieces, components, robots, nodes, installed, last_installation_s, makespan_s.
    """
    from bimrobot.core import io
    from bimrobot.replay.inputs import load_build
    from bimrobot.replay.record import is_replay_recording, write_rrd

    from bimrobot.replay.rcan import is_rcan_folder

    folders = [Path(out_dir)] + ([Path(simulation)] if simulation is not None else [])
    io.check_output(rrd_path, folder=False, inputs=folders, option="-o",
                    recognise=is_replay_recording)  # before the work, not after
    if simulation is None and is_rcan_folder(folders[0]) and not (folders[0] / "package").is_dir():
        from bimrobot.replay.inputs import load_rcan_alone

        record = load_rcan_alone(folders[0], Path(model) if model is not None else None)
    else:
        record = load_build(folders, Path(model) if model is not None else None, building)
    with io.atomic_output_file(rrd_path, inputs=record.inputs, recognise=is_replay_recording) as tmp:
        summary = write_rrd(record, tmp, start=start, name=Path(rrd_path).stem,
                            compact={"auto": None, "meshes": False, "boxes": True}[draw])
    return summary


__all__ = ["write_replay"]
