"""`bimrobot rcan ...`: the interaction log, the summary, exit codes and one-sentence errors."""

from __future__ import annotations

import json

from bimrobot.cli import main


def test_experiment_prints_the_interaction_log(capsys):
    assert main(["rcan", "run", "--experiment", "2", "--backend", "sim"]) == 0
    out = capsys.readouterr().out
    assert "== RCAN experiment 2: column that needs transport" in out
    assert "[component 267VPu8ab9991QBA3MI3UN] publishes E2.4 'Transport' target (4.00, 1.40, 0.00)" in out
    assert "[generation] RCAN node rcan/E2.4 instantiated: component 267VPu8ab9991QBA3MI3UN, activity 'Transport', robot husky_ur5, backend sim" in out
    assert "[rcan/E2.4] robot husky_ur5 executes 'Transport'" in out
    assert "[component 267VPu8ab9991QBA3MI3UN] state: Arrived" in out
    assert "== completed: 6/6 activities done; components: 1 Assembled" in out


def test_schedule_run_writes_report_and_resumes_as_done(tmp_path, schedule_csv, capsys):
    caps = tmp_path / "caps.yaml"
    from rcan_helpers import write_capabilities

    write_capabilities(caps)
    args = ["rcan", "run", "--schedule", str(schedule_csv), "--capabilities", str(caps), "-q",
            "--state-db", str(tmp_path / "s.sqlite"), "--report", str(tmp_path / "report.json")]
    assert main(args) == 0
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["status"] == "completed" and len(report["done"]) == 44
    assert set(report["component_states"].values()) == {"Assembled"}
    capsys.readouterr()
    assert main(args) == 0  # a finished run resumed: nothing is executed again
    assert "44/44 activities done" in capsys.readouterr().out


def test_escalation_exits_1_with_the_report(capsys):
    code = main(["rcan", "run", "--experiment", "1", "--failure-probability", "1", "--max-attempts", "2", "-q"])
    assert code == 1
    out = capsys.readouterr().out
    assert ("ESCALATED: Move to component of component 267VPu8ab9991QBA3MI3UN (activity E1.1) failed 2 time(s) "
            "on robot husky_ur5") in out


def test_escalation_with_independent_work_lists_escalated_blocked_and_done(tmp_path, capsys):
    from rcan_helpers import frame_schedule, write_capabilities

    schedule = frame_schedule(tmp_path / "s.csv", components=6)
    args = ["rcan", "run", "--schedule", str(schedule), "--capabilities", str(write_capabilities(tmp_path / "c.yaml")),
            "--failure-probability", "0.1", "--seed", "1", "--max-attempts", "1", "-q",
            "--report", str(tmp_path / "r.json")]
    assert main(args) == 1
    out = capsys.readouterr().out
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["status"] == "escalated" and report["done"] and report["blocked_by"]
    for escalation in report["escalations"]:
        assert f"(activity {escalation['activity_id']})" in out
    for cause in set(report["blocked_by"].values()):
        assert f"blocked by escalated {cause}: " in out
    assert f"done: {len(report['done'])} activities ({report['done'][0]}, " in out


def test_bad_input_exits_2_with_one_sentence_and_no_report(tmp_path, capsys):
    report = tmp_path / "report.json"
    cases = [
        (["--experiment", "1", "--failure-probability", "2"], "--failure-probability must be between 0 and 1"),
        (["--experiment", "1", "--no-local-executors"], "--no-local-executors needs --redis"),
        (["--schedule", str(tmp_path / "none.csv")], "none.csv"),
        (["--experiment", "1", "--capabilities", str(tmp_path / "none.yaml")], "neither a built-in fleet"),
        (["--experiment", "1", "--max-attempts", "0"], "--max-attempts must be at least 1"),
        (["--experiment", "1", "--redis", "redis://127.0.0.1:1/0"], "cannot reach Redis at redis://127.0.0.1:1/0"),
        (["--experiment", "1", "--redis", "http://nope"], "cannot reach Redis at http://nope"),
        (["--experiment", "1", "--capabilities", "fleet2", "--model-offset", "nan", "0"],
         "--model-offset must be two finite numbers"),
        (["--experiment", "1", "--capabilities", "fleet2", "--site", str(tmp_path / "none.yaml")], "none.yaml"),
    ]
    for extra, message in cases:
        assert main(["rcan", "run", *extra, "--report", str(report)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("bimrobot rcan: error: ") and message in err and err.count("\n") == 1
        assert not report.exists()


def test_capabilities_command_prints_table_5_2(capsys):
    assert main(["rcan", "capabilities"]) == 0
    out = capsys.readouterr().out
    assert "mobile_base    Move to component, Transport" in out
    assert "husky_ur5" in out and "payload 5 kg, reach 0.85 m" in out


def test_technician_fixes_the_cause_and_retries_the_escalated_activity(tmp_path, capsys):
    import sqlite3

    db = str(tmp_path / "state.sqlite")
    broken = ["rcan", "run", "--experiment", "1", "--state-db", db, "--max-attempts", "2", "-q"]
    assert main([*broken, "--failure-probability", "1"]) == 1
    assert "ESCALATED: Move to component" in capsys.readouterr().out
    assert main(broken) == 1  # resumed without --retry-escalated: still escalated, nothing re-executed
    assert main([*broken, "--retry-escalated"]) == 0  # the robot works again (p = 0)
    assert "5/5 activities done" in capsys.readouterr().out
    journal = sqlite3.connect(db).execute(
        "SELECT event, attempt FROM journal WHERE activity_id='E1.1' ORDER BY seq").fetchall()
    assert journal == [("started", 1), ("failed", 1), ("started", 2), ("escalated", 2), ("reopened", 2),
                       ("started", 3), ("done", 3)]


def test_ifc_work_schedule_runs_through_rcan(shared_ifc, tmp_path, capsys):
    """construction-scheduling-task.ifc: a slab and four walls in an IfcWorkSchedule; targets are the
    elements' placements. Its tasks build the elements where they stand (no transport task): a robot
    goes to each, positions and installs it, and the 13 t slab's weight limits no robot."""
    ifc = shared_ifc("construction-scheduling-task.ifc")
    assert main(["rcan", "run", "--schedule", str(ifc), "-q"]) == 0
    assert "components: 5 Assembled" in capsys.readouterr().out
    table = ("robot_types:\n"
             "  mobile_base: {activities: [move_to_component, transport]}\n"
             "  manipulator: {activities: [position_for_picking_up, position_for_installing]}\n"
             "  gripper: {activities: [pick_up, install]}\n"
             "robots:\n"
             "  small_crane: {types: [mobile_base, manipulator, TYPES], payload_kg: 2000, reach_m: 30,\n"
             "                speed_m_s: 0.5, handling_s: {install: 600}}\n")
    light = tmp_path / "light.yaml"
    light.write_text(table.replace(", TYPES", ", gripper"))
    assert main(["rcan", "run", "--schedule", str(ifc), "--capabilities", str(light), "-q"]) == 0
    assert "components: 5 Assembled" in capsys.readouterr().out
    no_gripper = tmp_path / "no_gripper.yaml"
    no_gripper.write_text(table.replace(", TYPES", ""))
    assert main(["rcan", "run", "--schedule", str(ifc), "--capabilities", str(no_gripper), "-q"]) == 2
    err = capsys.readouterr().err
    # every component no robot can take, in one sentence: the slab and the four walls
    assert "no robot can take 'Install' of component 20WrgxqpbDtferON_k1P2X" in err
    assert "4 more component(s) cannot be taken either; the heaviest weighs" in err and err.count("\n") == 1
