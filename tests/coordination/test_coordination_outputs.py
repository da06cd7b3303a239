"""Schedule CSV (the contract with lbd/rcan), the CLI and its outputs, the CP-SAT comparison."""

import csv
import json

import pytest

from bimrobot.cli import main
from bimrobot.site.fleet import load_fleet
from bimrobot.coordination.generate import generated_frame
from bimrobot.coordination.schedule import COLUMNS, load_schedule_csv, write_schedule_csv
from bimrobot.coordination.simulation import simulate
from bimrobot.core.errors import InputError
from bimrobot.sco import build_smart_model

CONVENTION_COLUMNS = [
    "Identification", "Name", "PredefinedType", "Activity", "GlobalId", "Robot", "Start", "Finish",
    "Duration", "Predecessors", "TargetX", "TargetY", "TargetZ", "Storey",
    "FromX", "FromY", "FromZ", "ToX", "ToY", "ToZ", "Nodes", "Points",  # the work of the one time model
]


def _result(nx=2, ny=2, floors=1, fleet="fleet2"):
    model = generated_frame(nx, ny, floors)
    smart = build_smart_model(model)
    return smart, simulate(smart, load_fleet(fleet), storey_elevations=[s.elevation for s in model.storeys])


def test_schedule_csv_follows_the_convention_and_round_trips(tmp_path):
    smart, result = _result()
    path = write_schedule_csv(result.activities, tmp_path / "schedule.csv")
    with open(path, newline="") as handle:
        header = next(csv.reader(handle))
    assert header == CONVENTION_COLUMNS == list(COLUMNS)
    rows = load_schedule_csv(path)
    assert [r["Identification"] for r in rows] == [f"A{i:04d}" for i in range(1, len(rows) + 1)]
    kinds = {r["Activity"]: r["PredefinedType"] for r in rows}
    assert kinds == {"transport": "LOGISTIC", "position": "INSTALLATION", "assemble": "CONSTRUCTION"}
    assert sum(r["Activity"] == "assemble" for r in rows) == len(smart.nodes)
    column_rows = [r for r in rows if r["GlobalId"] == "column-0-0-0"]
    assert [r["Activity"] for r in column_rows][:2] == ["transport", "position"]
    assert column_rows[0]["TargetX"] == pytest.approx(-0.127) and column_rows[0]["TargetZ"] == pytest.approx(0.02)
    assert column_rows[0]["Storey"] == "storey-0"
    assemble = next(r for r in rows if r["Activity"] == "assemble" and r["GlobalId"] == "column-0-0-0")
    assert "column-0-0-0:" in assemble["Name"]  # the node id is in the Name
    by_id = {r["Identification"]: r for r in rows}
    for r in rows:
        assert abs(r["Duration"] - (r["Finish"] - r["Start"])) < 1e-6  # exactly, as written
        for p in r["Predecessors"]:
            assert r["Start"] >= by_id[p]["Finish"] - 1e-3
    position = next(r for r in rows if r["Activity"] == "position" and r["GlobalId"] == "beam-0-x-0-0")
    transport = next(r for r in rows if r["Activity"] == "transport" and r["GlobalId"] == "beam-0-x-0-0")
    assert position["Predecessors"] == [transport["Identification"]]
    # the work the rows took (metres, model frame): a transport from the yard to the beam, its
    # two nodes positioned at once (per joint), per assemble row the node's bolts
    assert (transport["ToX"], transport["ToY"]) != (transport["FromX"], transport["FromY"])
    assert position["Nodes"] == smart.components["beam-0-x-0-0"].node_number == 2 and position["FromX"] is not None
    assert sum(r["Points"] for r in rows if r["Activity"] == "assemble") == sum(
        n.assembly_point_number for n in smart.nodes.values())


def test_bad_schedule_csv_names_line_and_column(tmp_path):
    _, result = _result()
    path = write_schedule_csv(result.activities, tmp_path / "schedule.csv")
    lines = path.read_text().splitlines()
    lines[3] = lines[3].replace(",LOGISTIC,transport,", ",LOGISTIC,fly,").replace(",INSTALLATION,position,", ",INSTALLATION,fly,")
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"schedule.csv, line 4: column Activity must be transport, position or assemble, got 'fly'"):
        load_schedule_csv(path)


def test_simulate_cli_writes_every_output(tmp_path, capsys):
    out = tmp_path / "sim"
    assert main(["simulate", "generated:2x2x1", "--fleet", "fleet1", "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "makespan" in printed and "AssemblyRobot31" in printed
    assert {p.name for p in out.iterdir()} == {
        "events.log", "events.jsonl", "robots.csv", "robots.txt", "summary.json", "states.json", "schedule.csv", "gantt.png",
        "site.yaml",  # the site the run used, placed on the building: --site of any later command
        "fleet.yaml",  # the fleet that built the schedule, in the one fleet format: --fleet of any later command
        "requests.csv", ".bimrobot-output.json",  # the marker that lets a later run replace the folder
    }
    summary = json.loads((out / "summary.json").read_text())
    assert summary["fleet"] == "fleet1" and summary["evaluator"] == "least-cost"
    assert load_fleet(out / "fleet.yaml").robots == load_fleet("fleet1").robots
    assert summary["smart_components"]["connection_nodes"] == 24
    # per node (the default): 8 transports (RCC), 20 node positionings released once their joint's partners
    # have arrived (ACC), 20 node assemblies once the node's position is fixed
    assert summary["work"] == "per-node"
    assert summary["requests_by_release"] == {"RCC": 8, "ACC": 20, "PositionFixed": 20}
    with open(out / "requests.csv") as handle:
        requests = list(csv.DictReader(handle))
    assert len(requests) == 48 and all(r["robot"] and r["finished_s"] for r in requests)
    assert (out / "gantt.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    log = (out / "events.log").read_text()
    assert "Start a new construction step, NO.1, in floor 1" in log
    assert "Publish transport requirements to robot" in log and "is arrived, TransportRobot11 is free for next work" in log
    events = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
    assert {"task_request", "award", "state", "finish", "floor_complete"} <= {e["event"] for e in events}
    with open(out / "robots.csv") as handle:
        robots = list(csv.DictReader(handle))
    assert [r["robot"] for r in robots] == ["TransportRobot11", "PositioningRobot21", "AssemblyRobot31"]
    assert float(robots[2]["busy_time_s"]) == pytest.approx(summary["robots"][2]["busy_time_s"])


@pytest.mark.parametrize(
    "argv, message",
    [
        (["generated:2x2x1", "--fleet", "nofleet.yaml"], "neither a built-in fleet"),
        (["missing.ifc", "--fleet", "fleet1"], "model file 'missing.ifc' does not exist"),
        (["generated:2x2x1", "--breakdown", "Nobody@5"], "breakdown names robot 'Nobody'"),
        (["generated:2x1x1", "--fleet", "fleet1", "--breakdown", "AssemblyRobot31@10"], "no working robot can assemble"),
    ],
)
def test_simulate_cli_bad_input_exits_2_without_output(tmp_path, capsys, argv, message):
    out = tmp_path / "sim"
    assert main(["simulate", *argv, "-o", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()
    assert not list(tmp_path.iterdir())  # no temporary folder left behind either


def test_help_shows_an_example(capsys):
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    assert "bimrobot simulate frame.ifc --fleet fleet2 -o sim/" in capsys.readouterr().out


def test_optimal_schedule_bounds_the_market_and_matches_it_on_one_robot_chain(tmp_path, capsys):
    pytest.importorskip("ortools")
    from bimrobot.planning.optimal import solve_optimal

    model = generated_frame(2, 1, 1)
    elevations = [s.elevation for s in model.storeys]
    optimum = solve_optimal(build_smart_model(model), load_fleet("fleet2"), storey_elevations=elevations, time_limit_s=60)
    assert optimum.status == "OPTIMAL" and optimum.tasks == 10
    for evaluator in ("least-cost", "quickest-finish", "greedy-nearest", "random"):
        # the optimum's task graph is per component / per joint: compare the market on the same tasks
        market = simulate(build_smart_model(model), load_fleet("fleet2"), evaluator=evaluator, storey_elevations=elevations, per_node=False)
        assert optimum.makespan <= market.makespan + 0.05
    # assembly alone needs 72 bolts between a 60 s and a 30 s robot: at least 72 x 20 s
    assert optimum.makespan >= 72 * 20
    assert main(["allocators", "generated:2x1x1", "--fleet", "fleet2", "--seeds", "2", "-o", str(tmp_path / "cmp")]) == 0
    rows = json.loads((tmp_path / "cmp" / "allocators.json").read_text())
    assert rows[-1]["allocator"] == "optimal (CP-SAT)" and rows[-1]["gap_pct"] == 0.0
    assert all(row["gap_pct"] >= -0.01 for row in rows)


def test_prebuilt_classes_are_on_site_from_the_start(tmp_path, capsys):
    out = tmp_path / "sim"
    assert main(["simulate", "generated:2x1x1", "--fleet", "fleet2", "--prebuilt", "IfcFooting,IfcColumn", "-o", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["smart_components"]["prebuilt"]) == 4  # 2 footings + 2 columns
    rows = load_schedule_csv(out / "schedule.csv")
    assert {r["GlobalId"] for r in rows if r["Activity"] == "transport"} == {"beam-0-x-0-0"}
    capsys.readouterr()
    assert main(["simulate", "generated:2x1x1", "--prebuilt", "IfcSlb", "-o", str(tmp_path / "bad")]) == 2
    assert capsys.readouterr().err.strip().endswith(
        "--prebuilt names 'IfcSlb', which is not an IFC class (this model's classes: IfcBeam, IfcColumn, IfcFooting, IfcPlate)"
    )
    assert not (tmp_path / "bad").exists()
