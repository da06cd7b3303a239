"""Helpers shared by the RCAN tests: fleets (and older capability tables) and schedules built in the test, journal probes."""

from __future__ import annotations

from pathlib import Path

from bimrobot.schedule.csv import write_schedule_csv
from bimrobot.core.tasks import Activity
from bimrobot.rcan.generation import parse_capabilities

TABLE_5_2 = {
    "mobile_base": {"activities": ["move_to_component", "transport"]},
    "manipulator": {"activities": ["position_for_picking_up", "position_for_installing"]},
    "gripper": {"activities": ["pick_up", "install"]},
}


#: A mobile manipulator that carries and lifts 1000 kg, reaches 5 m, picks up in 10 s and installs in 20 s
#: (the one fleet format; homes in the model frame).
CRANE = {"kind": "mobile_manipulator", "speed_m_s": 1.0, "carry_kg": 1000, "lift_kg": 1000, "platform_m": [5.0, 1.0],
         "reach_m": 5.0, "arm_speed_m_s": 0.5, "load_s": 10, "time_per_node_s": 20, "time_per_point_s": 20}


def two_cranes() -> dict:
    """The two-crane fleet file's keys: crane_a at the origin, crane_b 5 m along x."""
    return {"version": 2, "name": "two-cranes", "home_frame": "model", "robots": [
        {"name": "crane_a", **CRANE, "home_m": [0.0, 0.0, 0.0]}, {"name": "crane_b", **CRANE, "home_m": [5.0, 0.0, 0.0]}]}


def two_crane_capabilities():
    """Two identical mobile manipulators that carry 1000 kg and reach 5 m."""
    return parse_capabilities(two_cranes(), "test table")


def frame_schedule(path: Path, components: int = 4) -> Path:
    """A schedule of ``components`` columns: transport, position, assemble each; columns 2.. wait for
    the previous column's assembly (a chain through the frame)."""
    rows, previous = [], ()
    for i in range(components):
        gid = f"COL{i:02d}xxxxxxxxxxxxxxxxx"[:22]
        target = (3.0 * i, 4.0, 0.0)
        t, p, a = f"A{3 * i + 1:04d}", f"A{3 * i + 2:04d}", f"A{3 * i + 3:04d}"
        start = 100.0 * i
        rows += [
            Activity(t, f"Transport {gid}", "transport", gid, None, start, start + 30, previous, target),
            Activity(p, f"Position {gid}", "position", gid, None, start + 30, start + 40, (t,), target),
            Activity(a, f"Assemble {gid}", "assemble", gid, None, start + 40, start + 60, (p,), target),
        ]
        previous = (a,) if i % 2 else ()  # two independent chains: both robots work
    return write_schedule_csv(rows, path)



def write_capabilities(path: Path) -> Path:
    """The two-crane fleet as a YAML file (for CLI runs in subprocesses)."""
    import yaml

    path.write_text(yaml.safe_dump(two_cranes()))
    return path


def done_count(db: Path) -> int:
    """How many activities the state database records as done (0 before it or its tables exist).

    Opened read-only: a plain connect would create an empty file at ``db``, which the run then
    refuses as a file bimrobot did not write."""
    import sqlite3
    from urllib.parse import quote

    try:
        con = sqlite3.connect(f"file:{quote(str(db))}?mode=ro", uri=True)
    except sqlite3.OperationalError:  # not created yet
        return 0
    try:
        return con.execute("SELECT COUNT(*) FROM activity WHERE status='done'").fetchone()[0]
    except sqlite3.OperationalError:  # killed before the tables were created
        return 0
    finally:
        con.close()
