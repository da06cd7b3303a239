"""Schedule import: the CSV of docs/conventions.md (validated, with file and line in every error) and
the IFC work schedule of construction-scheduling-task.ifc."""

from __future__ import annotations

import pytest

from bimrobot.core.errors import InputError
from bimrobot.schedule.csv import load_schedule_csv, write_schedule_csv
from bimrobot.schedule.task_rows import load_schedule_ifc
from shared_data import shared_file

HEADER = "Identification,Name,PredefinedType,Activity,GlobalId,Robot,Start,Finish,Duration,Predecessors,TargetX,TargetY,TargetZ,Storey\n"
GOOD_ROWS = [
    "A1,Transport C1,LOGISTIC,transport,COL,Transport 1,0,100,100,,1.0,2.0,0.025,L1",
    "A2,Position C1,INSTALLATION,position,COL,Positioning 1,100,220,120,A1,1.0,2.0,0.025,L1",
    "A3,Assemble PLATE:COL,CONSTRUCTION,assemble,COL,Assembly 1,220,280,60,A2,1.0,2.0,0.025,L1",
    "A4,Transport B1,LOGISTIC,transport,BEAM,Transport 1,100,200,100,,3.5,0,4.0,L2",
]


def write_csv(tmp_path, rows, header=HEADER):
    path = tmp_path / "schedule.csv"
    path.write_text(header + "\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_csv_rows_become_activities_with_times_sequence_robot_and_target(tmp_path):
    schedule = load_schedule_csv(write_csv(tmp_path, GOOD_ROWS))
    assert [a.id for a in schedule] == ["A1", "A2", "A3", "A4"]
    a3 = schedule["A3"]
    assert (a3.activity, a3.global_id, a3.robot) == ("assemble", "COL", "Assembly 1")
    assert (a3.start, a3.finish, a3.duration) == (220.0, 280.0, 60.0)
    assert a3.predecessors == ("A2",)
    assert a3.target == (1.0, 2.0, 0.025)
    assert a3.node_id == "PLATE:COL"  # the connection node named in an assemble row
    assert schedule["A1"].node_id is None
    assert schedule.makespan == 280.0
    assert [a.id for a in schedule.of_component("COL")] == ["A1", "A2", "A3"]
    assert [a.id for a in schedule.ready(done=[])] == ["A1", "A4"]
    assert [a.id for a in schedule.ready(done=["A1", "A4"])] == ["A2"]
    assert [a.id for a in schedule.topological_order()] == ["A1", "A2", "A4", "A3"]


def test_csv_round_trip_keeps_every_field(frame_schedule_csv, frame_model, tmp_path):
    schedule = load_schedule_csv(frame_schedule_csv, model=frame_model)
    again = load_schedule_csv(write_schedule_csv(schedule, tmp_path / "again.csv"), model=frame_model)
    assert again.activities == schedule.activities
    assert len(schedule) == 28  # 4 columns and 4 beams x (transport, position, assemble per node)


@pytest.mark.parametrize(
    "row_index, bad_row, message",
    [
        (1, "A2,x,INSTALLATION,position,COL,P,abc,220,,A1,,,,", "line 3: Start 'abc' is not a number of seconds"),
        (1, "A2,x,INSTALLATION,position,COL,P,100,-5,,A1,,,,", "line 3: Finish '-5' must be a finite number"),
        (1, "A2,x,INSTALLATION,position,COL,P,220,100,,A1,,,,", "line 3: Finish 100.0 s is before Start 220.0 s"),
        (1, "A2,x,INSTALLATION,position,COL,P,100,220,99,A1,,,,", "line 3: Duration 99.0 s is not Finish - Start"),
        (1, "A1,x,INSTALLATION,position,COL,P,100,220,,,,,,", "line 3: Identification 'A1' is already used on line 2"),
        (1, "A2,x,INSTALLATION,position,COL,P,100,220,,A9,,,,", "line 3: predecessor 'A9' of A2 is not an activity"),
        (1, "A2,x,INSTALLATION,position,COL,P,50,220,,A1,,,,", "line 3: A2 starts at 50.0 s, before its predecessor A1 finishes at 100.0 s"),
        (1, "A2,x,INSTALLATION,fly,COL,P,100,220,,A1,,,,", "line 3: column Activity must be transport, position or assemble, got 'fly'"),
        (1, "A2,x,BOGUS,position,COL,P,100,220,,A1,,,,", "line 3: PredefinedType 'BOGUS' is not an IfcTaskTypeEnum"),
        (1, "A2,x,INSTALLATION,position,,P,100,220,,A1,,,,", "line 3: GlobalId is empty"),
        (1, "A2,x,INSTALLATION,position,COL,P,100,220,,A1,1,two,3,", "line 3: TargetY 'two' is not a number of metres"),
        # valid float syntax, impossible values: refused with file, line and column
        (1, "A2,x,INSTALLATION,position,COL,P,nan,220,,A1,,,,", "line 3: Start 'nan' must be a finite number of seconds"),
        (1, "A2,x,INSTALLATION,position,COL,P,100,inf,,A1,,,,", "line 3: Finish 'inf' must be a finite number of seconds"),
        (1, "A2,x,INSTALLATION,position,COL,P,100,1e308,,A1,,,,", "line 3: Finish '1e308' must be a finite number of seconds >= 0 and <= 1e+09"),
        (1, "A2,x,INSTALLATION,position,COL,P,100,220,NaN,A1,,,,", "line 3: Duration 'NaN' must be a finite number"),
        (1, "A2,x,INSTALLATION,position,COL,P,100,220,,A1,1,2,1e308,", "line 3: TargetZ '1e308' must be a finite number of metres"),
        (1, "A2,x,INSTALLATION,position,COL,P,100,220,,A1,-inf,2,3,", "line 3: TargetX '-inf' must be a finite number of metres"),
        (1, "A2,x,INSTALLATION,position,COL,P,100,220,,A2,,,,", "line 3: activity A2 lists itself as a predecessor"),
    ],
)
def test_bad_csv_rows_name_file_and_line(tmp_path, row_index, bad_row, message):
    rows = list(GOOD_ROWS)
    rows[row_index] = bad_row
    path = write_csv(tmp_path, rows)
    with pytest.raises(InputError) as error:
        load_schedule_csv(path)
    assert str(path) in str(error.value)
    assert message in str(error.value)


def test_cycle_in_predecessors_is_reported_with_its_activities(tmp_path):
    rows = [
        "A1,x,LOGISTIC,transport,COL,T,0,0,,A3,,,,",
        "A2,x,INSTALLATION,position,COL,P,0,0,,A1,,,,",
        "A3,x,CONSTRUCTION,assemble,COL,A,0,0,,A2,,,,",
    ]
    with pytest.raises(InputError, match=r"line \d: the predecessors form a cycle A\d -> A\d -> A\d -> A\d"):
        load_schedule_csv(write_csv(tmp_path, rows))


def test_unknown_globalid_is_checked_against_the_model(tmp_path, frame_model):
    storey = frame_model.storeys[0].global_id
    column = frame_model.by_class("IfcColumn")[0].global_id
    rows = [
        f"A1,x,LOGISTIC,transport,{column},T,0,10,,,,,,{storey}",
        f"A2,x,LOGISTIC,transport,3XXXXXXXXXXXXXXXXXXXXX,T,10,20,,A1,,,,{storey}",
    ]
    with pytest.raises(InputError, match=r"line 3: GlobalId '3XXXXXXXXXXXXXXXXXXXXX' is not an element of .*steel_frame.ifc"):
        load_schedule_csv(write_csv(tmp_path, rows), model=frame_model)
    rows[1] = f"A2,x,LOGISTIC,transport,{column},T,10,20,,A1,,,,NOSTOREY"
    with pytest.raises(InputError, match="line 3: Storey 'NOSTOREY' is not a storey"):
        load_schedule_csv(write_csv(tmp_path, rows), model=frame_model)


def test_missing_column_and_missing_file(tmp_path):
    path = write_csv(tmp_path, ["A1,transport,COL,0"], header="Identification,Activity,GlobalId,Start\n")
    with pytest.raises(InputError, match=r"line 1: missing column\(s\) Finish"):
        load_schedule_csv(path)
    with pytest.raises(InputError, match="cannot read the schedule"):
        load_schedule_csv(tmp_path / "absent.csv")


def test_ifc_work_schedule_tasks_sequences_and_assigned_elements(shared_ifc):
    schedule = load_schedule_ifc(shared_ifc("construction-scheduling-task.ifc"))
    # 8 IfcTask: 5 leaves (slab, 4 walls) and 3 summary tasks (Ground Level, Slab, Wall).
    assert len(schedule.activities) == 5 and len(schedule.phases) == 3
    assert sorted(p.name for p in schedule.phases) == ["Ground Level", "Slab (Standard)", "Wall (Standard)"]
    assert sum(len(a.predecessors) for a in schedule.activities) == 7  # the 7 FINISH_START IfcRelSequence
    names = [a.name for a in schedule.topological_order()]
    assert names == ["Slab #1", "Wall #1", "Wall #2", "Wall #3", "Wall #4"]
    assert schedule.epoch == "2010-09-20T08:00:00"
    wall2 = next(a for a in schedule if a.name == "Wall #2")
    assert (wall2.start, wall2.finish) == (2 * 86400.0, 2 * 86400.0 + 8 * 3600.0)  # 22 Sep 08:00-16:00
    assert wall2.global_id == "2qqyx9mIf27vQuEGt7ts8$"  # the IfcWall the task is assigned to
    assert wall2.storey == "3nYYuCp$XC4vhvJ2cMbpd2"
    assert wall2.activity == "assemble"
    assert {schedule[p].name for p in wall2.predecessors} == {"Slab #1", "Wall #1"}


def test_ifc_without_tasks_is_an_input_error(shared_ifc):
    with pytest.raises(InputError, match="has no IfcTask"):
        load_schedule_ifc(shared_ifc("column-extruded-solid.ifc"))


def test_header_only_schedule_is_an_error_not_an_empty_build(tmp_path):
    path = tmp_path / "schedule.csv"
    path.write_text(HEADER, encoding="utf-8")
    with pytest.raises(InputError, match="schedule.csv has a header but no activity"):
        load_schedule_csv(path)
    path.write_text(HEADER + "\n\n", encoding="utf-8")  # blank lines are no activities either
    with pytest.raises(InputError, match="has a header but no activity"):
        load_schedule_csv(path)
    path.write_text("", encoding="utf-8")
    with pytest.raises(InputError, match=r"line 1: missing column\(s\) Identification"):
        load_schedule_csv(path)


def test_leading_comment_lines_are_skipped_and_line_numbers_stay_true(tmp_path):
    path = tmp_path / "schedule.csv"
    path.write_text("# written by bimrobot 0.1.0 (simulate)\n" + HEADER + "\n".join(GOOD_ROWS) + "\n", encoding="utf-8")
    assert [a.id for a in load_schedule_csv(path)] == ["A1", "A2", "A3", "A4"]
    rows = list(GOOD_ROWS)
    rows[1] = "A2,x,INSTALLATION,position,COL,P,100,nan,,A1,,,,"
    path.write_text("# a comment\n" + HEADER + "\n".join(rows) + "\n", encoding="utf-8")
    with pytest.raises(InputError, match="line 4: Finish 'nan'"):  # the file's own line 4
        load_schedule_csv(path)


def test_a_schedule_file_that_is_no_csv_is_one_sentence(tmp_path, shared_ifc):
    with pytest.raises(InputError, match=r"line 1: missing column\(s\) Identification, Activity"):
        load_schedule_csv(shared_ifc("column-extruded-solid.ifc"))  # an IFC given as the schedule
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe\x00")
    with pytest.raises(InputError, match="is not a UTF-8 text file"):
        load_schedule_csv(binary)
    with pytest.raises(InputError, match="is a folder, not a CSV file"):
        load_schedule_csv(tmp_path)


def test_real_schependomlaan_event_log_is_refused_as_not_a_bimrobot_schedule():
    """The project's real as-planned event log is a 4D log, not a bimrobot schedule: one sentence."""
    log = shared_file("schedules", "schependomlaan-eventlog-as-planned.csv")
    with pytest.raises(InputError, match=r"missing column\(s\) .*a bimrobot schedule CSV is expected"):
        load_schedule_csv(log)


def test_written_schedule_is_replaced_but_a_foreign_csv_is_not(tmp_path):
    schedule = load_schedule_csv(write_csv(tmp_path, GOOD_ROWS))
    out = tmp_path / "out.csv"
    write_schedule_csv(schedule, out)
    write_schedule_csv(schedule, out)  # bimrobot's own schedule: replaced
    assert load_schedule_csv(out).activities == schedule.activities
    foreign = tmp_path / "mine.csv"
    foreign.write_text("name,value\nx,1\n")
    before = foreign.read_bytes()
    with pytest.raises(InputError, match="existing file that bimrobot did not write"):
        write_schedule_csv(schedule, foreign)
    assert foreign.read_bytes() == before


# ------------------------------------------------------------------ bounded input, one sentence each (issue 35)


def test_a_row_with_more_cells_than_the_header_is_refused_naming_its_line(tmp_path):
    path = write_csv(tmp_path, [GOOD_ROWS[0], GOOD_ROWS[1] + ",extra"])
    with pytest.raises(InputError, match=r"schedule.csv, line 3: 15 cells, but the header has 14 columns"):
        load_schedule_csv(path)


def test_a_column_named_twice_in_the_header_is_refused(tmp_path):
    path = write_csv(tmp_path, [GOOD_ROWS[0] + ",L9"], header=HEADER.rstrip("\n") + ",Storey\n")
    with pytest.raises(InputError, match=r"line 1: column 'Storey' appears more than once"):
        load_schedule_csv(path)


@pytest.mark.parametrize("column, cell", [("GlobalId", '"CO\rL"'), ("Identification", '"A\n1"'), ("Robot", '"T\x1b1"'),
                                          ("Identification", "A 1"), ("Storey", '"L\t1"')])
def test_an_id_with_a_control_character_or_a_space_is_refused_in_one_sentence(tmp_path, column, cell):
    cells = GOOD_ROWS[0].split(",")
    cells[HEADER.rstrip("\n").split(",").index(column)] = cell
    path = write_csv(tmp_path, [",".join(cells)])
    with pytest.raises(InputError, match=rf"schedule.csv, line 2: {column} .* contains (a control character|white space)") as error:
        load_schedule_csv(path)
    assert "\n" not in str(error.value) and "\r" not in str(error.value)


def test_the_writer_refuses_what_the_reader_would_refuse_and_quotes_free_text(tmp_path):
    from bimrobot.core.tasks import Activity

    def activity(**changes) -> Activity:
        fields = dict(id="A1", name="Lift, then\r\nturn \"slowly\"", activity="transport", global_id="COL",
                      robot="Transport 1", start=0.0, finish=100.0)
        return Activity(**{**fields, **changes})

    path = write_schedule_csv([activity()], tmp_path / "ok.csv")
    assert load_schedule_csv(path)["A1"].name == "Lift, then\r\nturn \"slowly\""  # quoted: round trip
    for changes, message in [({"global_id": "CO\rL"}, "its GlobalId 'CO\\\\rL' contains a control character"),
                             ({"id": "A 1"}, "Identification 'A 1' contains white space"),
                             ({"finish": 2e9}, "Finish 2e\\+09 s is not within 0 to 1e\\+09 s"),
                             ({"target": (0.0, 0.0, 1e300)}, "target .* is not within")]:
        with pytest.raises(InputError, match=message):
            write_schedule_csv([activity(**changes)], tmp_path / "bad.csv")
        assert not (tmp_path / "bad.csv").exists()


def test_row_and_per_component_limits_name_the_variable_that_raises_them(tmp_path, monkeypatch):
    path = write_csv(tmp_path, GOOD_ROWS)
    monkeypatch.setenv("BIMROBOT_SCHEDULE_MAX_ROWS", "3")
    with pytest.raises(InputError, match=r"line 5: the schedule has more than 3 rows, the limit; .*BIMROBOT_SCHEDULE_MAX_ROWS"):
        load_schedule_csv(path)
    monkeypatch.setenv("BIMROBOT_SCHEDULE_MAX_ROWS", "4")
    assert len(load_schedule_csv(path)) == 4
    monkeypatch.setenv("BIMROBOT_SCHEDULE_MAX_PER_COMPONENT", "2")
    with pytest.raises(InputError, match=r"line 4: component 'COL' has more than 2 activities.*BIMROBOT_SCHEDULE_MAX_PER_COMPONENT"):
        load_schedule_csv(path)
    monkeypatch.setenv("BIMROBOT_SCHEDULE_MAX_PER_COMPONENT", "many")
    with pytest.raises(InputError, match=r"BIMROBOT_SCHEDULE_MAX_PER_COMPONENT='many' must be a whole number >= 1"):
        load_schedule_csv(path)


def test_a_schedule_over_the_size_limit_is_refused_before_it_is_read(tmp_path, monkeypatch):
    path = write_csv(tmp_path, GOOD_ROWS * 6000)  # duplicate ids: refused on line 6 if it were read
    assert path.stat().st_size > 1_000_000
    monkeypatch.setenv("BIMROBOT_SCHEDULE_MAX_MB", "1")
    with pytest.raises(InputError, match=r"is 2 MB, more than the 1 MB a schedule CSV may have; .*BIMROBOT_SCHEDULE_MAX_MB"):
        load_schedule_csv(path)


def test_one_component_transported_250000_times_is_refused_at_the_limit_not_loaded(tmp_path):
    rows = "".join(f"T{n},,,transport,COL,,0,1,,,,,,\n" for n in range(250_000))
    path = tmp_path / "schedule.csv"
    path.write_text(HEADER + rows)
    with pytest.raises(InputError, match=r"line 1002: component 'COL' has more than 1,000 activities"):
        load_schedule_csv(path)
