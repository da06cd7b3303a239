"""`bimrobot rcan`'s writing options under the output policy: `rcan run --report`, `--graph` and
`--state-db`, `rcan executor --state-db` and `rcan robot-node --state-db`. A refused path is one
sentence with exit 2 and leaves every file byte for byte; bimrobot's own outputs are replaced (the
report, the graph) or resumed (the state database); a user's SQLite database never gets a table."""

from __future__ import annotations

import csv
import json
import sqlite3
from pathlib import Path

import pytest

from bimrobot.cli import main
from bimrobot.rcan.state_db import APPLICATION_ID, is_state_db
from rcan_helpers import frame_schedule, write_capabilities
from output_checks import snapshot


@pytest.fixture
def site(tmp_path, steel_frame_ifc, monkeypatch):
    """A user's disk: project/ with a model, schedule and capability table; a foreign folder, a link to
    it, a regular file, a user's SQLite database; the current directory is an empty work folder."""
    project = tmp_path / "project"
    project.mkdir()
    model = project / "frame.ifc"
    model.write_bytes(steel_frame_ifc.read_bytes())
    schedule = frame_schedule(project / "schedule.csv")
    caps = write_capabilities(project / "caps.yaml")
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("my notes\n")
    (tmp_path / "link").symlink_to(mine, target_is_directory=True)
    (tmp_path / "somefile.txt").write_text("a file\n")
    user_db = tmp_path / "user.sqlite"
    con = sqlite3.connect(user_db)
    con.execute("CREATE TABLE invoices (id INTEGER PRIMARY KEY, amount REAL)")
    con.execute("INSERT INTO invoices (amount) VALUES (12.5)")
    con.commit()
    con.close()
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    return {"root": tmp_path, "model": model, "schedule": schedule, "caps": caps, "user_db": user_db}


def cases(site: dict) -> dict[str, tuple[str, str]]:
    """Case name -> (path to give, words the one-sentence refusal must contain)."""
    root = site["root"]
    return {
        "the current directory": (".", "is the current directory"),
        "the input file": (str(site["schedule"]), "is an input of this command"),
        "the model": (str(site["model"]), "is an input of this command"),
        "a parent of the input": (str(site["schedule"].parent), "is a folder"),
        "a non-empty foreign folder": (str(root / "mine"), "is a folder"),
        "a symlink to a foreign folder": (str(root / "link"), "is a folder"),
        "a path under a regular file": (str(root / "somefile.txt" / "out.json"), "is a file, not a folder, so nothing can be written under it"),
        "a foreign file": (str(root / "somefile.txt"), "is an existing file that bimrobot did not write"),
        "a foreign SQLite database": (str(site["user_db"]), "did not write"),
    }


def run_args(site: dict) -> list[str]:
    return ["rcan", "run", "--schedule", str(site["schedule"]), "--model", str(site["model"]),
            "--capabilities", str(site["caps"]), "-q"]


def refused(args: list[str], root: Path, words: str, capsys) -> None:
    before = snapshot(root)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("bimrobot rcan: error: ") and words in err and err.count("\n") == 1, err
    assert snapshot(root) == before  # every file byte for byte, nothing added


CASES = ["the current directory", "the input file", "the model", "a parent of the input", "a non-empty foreign folder",
         "a symlink to a foreign folder", "a path under a regular file", "a foreign file", "a foreign SQLite database"]


@pytest.mark.parametrize("option", ["--report", "--graph-out", "--state-db"])
@pytest.mark.parametrize("case", CASES)
def test_run_outputs_are_refused_before_the_run(site, option, case, capsys):
    target, words = cases(site)[case]
    refused([*run_args(site), option, target], site["root"], f"{option} ", capsys)
    refused([*run_args(site), option, target], site["root"], words, capsys)


@pytest.mark.parametrize("case", ["the current directory", "a non-empty foreign folder", "a path under a regular file",
                                  "a foreign SQLite database"])
def test_executor_and_robot_node_state_db_are_refused(site, case, capsys):
    target, words = cases(site)[case]
    # the executor checks its path before it connects to Redis (nothing listens on port 1)
    refused(["rcan", "executor", "--redis", "redis://127.0.0.1:1/0", "--state-db", target], site["root"], words, capsys)
    refused(["rcan", "robot-node", "--state-db", target], site["root"], words, capsys)


def test_a_users_sqlite_database_gets_no_table(site, capsys):
    user_db = site["user_db"]
    before = user_db.read_bytes()
    assert main(["rcan", "run", "--experiment", "1", "-q", "--state-db", str(user_db)]) == 2
    assert "did not write" in capsys.readouterr().err
    assert user_db.read_bytes() == before
    tables = sqlite3.connect(user_db).execute("SELECT name FROM sqlite_master WHERE type='table'").fetchall()
    assert tables == [("invoices",)]
    # the library refuses it too, not only the command line
    from bimrobot.core.errors import InputError
    from bimrobot.rcan.state_manager import StateStore

    with pytest.raises(InputError, match="is not a bimrobot state database"):
        StateStore(user_db)
    assert user_db.read_bytes() == before


def test_state_db_is_marked_and_resumed_and_the_same_path_twice_is_refused(site, capsys):
    db = Path("state.sqlite")
    assert main(["rcan", "run", "--experiment", "1", "-q", "--state-db", str(db)]) == 0
    header = db.read_bytes()[:100]
    assert header.startswith(b"SQLite format 3\x00") and int.from_bytes(header[68:72], "big") == APPLICATION_ID
    assert is_state_db(db) and not is_state_db(site["user_db"])
    capsys.readouterr()
    assert main(["rcan", "run", "--experiment", "1", "-q", "--state-db", str(db)]) == 0  # resumed, not replaced
    assert "5/5 activities done" in capsys.readouterr().out
    refused(["rcan", "run", "--experiment", "1", "-q", "--state-db", "new.sqlite", "--report", "./new.sqlite"],
            site["root"], "--report and --state-db name the same file", capsys)


@pytest.mark.parametrize("failure, words", [
    (["--capabilities", "light"], "no robot can take"),
    (["--redis", "redis://127.0.0.1:1/0"], "cannot reach Redis"),
    (["--max-attempts", "0"], "--max-attempts must be at least 1"),
])
def test_a_run_that_fails_before_its_first_activity_leaves_no_state_file(site, failure, words, capsys):
    light = Path("light.yaml")  # a table without any manipulator or gripper: nobody picks anything up
    light.write_text(
        "robot_types:\n  base: {activities: [move_to_component, transport]}\n"
        "robots:\n  cart: {types: [base], payload_kg: 100}\n")
    failure = [str(light) if f == "light" else f for f in failure]
    args = ["rcan", "run", "--schedule", str(site["schedule"]), "-q", "--state-db", "new/state.sqlite", *failure]
    assert main(args) == 2
    assert words in capsys.readouterr().err
    assert not Path("new").exists()  # neither the file nor its -wal/-shm, nor the folder made for it
    assert not list(Path(".").glob("**/*.sqlite*"))


def test_report_and_graph_are_signed_and_replaced(site, capsys):
    from bimrobot.lbd.graph import ConstructionGraph

    frame_model_schedule = Path("sim")
    assert main(["simulate", str(site["model"]), "--fleet", "fleet2", "-o", str(frame_model_schedule)]) == 0
    args = ["rcan", "run", "--schedule", "sim/schedule.csv", "--model", str(site["model"]), "-q",
            "--capabilities", "fleet2", "--report", "report.json", "--graph-out", "after.ttl"]
    assert main(args) == 0
    report = json.loads(Path("report.json").read_text())
    assert report["generator"].startswith("written by bimrobot ") and report["status"] == "completed"
    assert report["unknown_weight"]["rule"].startswith("assume volume x 2400 kg/m3")
    assert Path("after.ttl").read_text().startswith("# written by bimrobot ")
    first = json.loads(Path("report.json").read_text())["done"][0].split(".")[0]
    assert ConstructionGraph.open("after.ttl").activity_state(first) == "Completed"
    capsys.readouterr()
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "bimrobot: replacing report.json (a file bimrobot wrote)" in err
    assert "bimrobot: replacing after.ttl (a file bimrobot wrote)" in err


def test_unknown_weights_follow_the_one_rule(tmp_path, shared_ifc, monkeypatch, capsys):
    """ifcColumn.ifc's slab has no weight: refused with `--unknown-weight refuse`, else volume x density,
    reported in one line and in the report; without a model, weights are unknown and said to be."""
    model = shared_ifc("ifcColumn.ifc")
    monkeypatch.chdir(tmp_path)
    schedule = Path("slab.csv")
    schedule.write_text("Identification,Activity,GlobalId,Start,Finish,TargetX,TargetY,TargetZ\n"
                        "A1,transport,3Gf$pjBEz48OGoobcejqH_,0,60,-4.5,0.4,-0.6\n")
    common = ["rcan", "run", "--schedule", str(schedule), "--model", str(model), "-q"]
    assert main([*common, "--unknown-weight", "refuse"]) == 2
    err = capsys.readouterr().err
    assert "--unknown-weight is refuse" in err and "IfcSlab" in err and err.count("\n") == 1
    assert main([*common, "--report", "r.json"]) == 0
    out = capsys.readouterr().out
    assert "have no weight in the model" in out and "concrete 2400 kg/m3 for 1" in out and "(--unknown-weight)" in out
    report = json.loads(Path("r.json").read_text())["unknown_weight"]
    assert report["by_class"]["IfcSlab"] == 1 and report["elements"]["3Gf$pjBEz48OGoobcejqH_"] > 100  # kg, not 0
    assert report["components_with_unknown_weight"] == []
    assert main(["rcan", "run", "--schedule", str(schedule), "-q", "--report", "r.json"]) == 0
    assert "1 component(s) have an unknown weight (no --model gives their weights)" in capsys.readouterr().out
    assert json.loads(Path("r.json").read_text())["unknown_weight"]["components_with_unknown_weight"] == ["3Gf$pjBEz48OGoobcejqH_"]


def test_simulated_schedule_robots_and_selection(site, capsys):
    """The schedule `simulate` writes names fleet robots the built-in rcan-robots fleet does not have: the
    run is refused in one sentence unless --reallocate gives the work to the table's robots (one line says
    so); with the schedule's own fleet it runs on the robots the schedule assigned. --include/--exclude
    choose the model's elements as everywhere else."""
    assert main(["simulate", str(site["model"]), "--fleet", "fleet2", "-o", "sim"]) == 0
    capsys.readouterr()
    args = ["rcan", "run", "--schedule", "sim/schedule.csv", "--model", str(site["model"]), "-q"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "which built-in fleet rcan-robots does not have" in err and "--fleet fleet2" in err
    assert err.count("\n") == 1
    assert main([*args, "--reallocate"]) == 0
    out = capsys.readouterr().out
    notice = [line for line in out.splitlines() if line.startswith("the schedule names robot(s)")]
    assert len(notice) == 1 and "which are not in built-in fleet rcan-robots" in notice[0]
    args += ["--capabilities", "fleet2"]  # the older name of --fleet, kept for users' scripts
    assert main([*args, "--state-db", "fleet.db"]) == 0
    assigned = {row["Identification"]: row["Robot"] for row in csv.DictReader(open("sim/schedule.csv", encoding="utf-8"))}
    with sqlite3.connect("fleet.db") as db:
        executed = dict(db.execute("SELECT activity_id, robot FROM activity"))
    assert executed and all(robot == assigned[activity.rsplit(".", 1)[0]] for activity, robot in executed.items())
    assert main([*args, "--include", "IfcNoSuchClass"]) == 2
    assert "names 'IfcNoSuchClass', which is not an IFC4 class" in capsys.readouterr().err
    assert main([*args, "--include", "IfcBeam"]) == 2  # the schedule's columns are not chosen
    err = capsys.readouterr().err
    assert "is not an element of" in err and "left out by --include/--exclude" in err and err.count("\n") == 1
