"""``bimrobot assembly from-ifc``: a storey's columns and beams become a custom scenario the env, the
validator and the exact planner accept; what is dropped is said; bad requests are one sentence."""

from __future__ import annotations

import pytest

from bimrobot.assembly.env import AssemblyEnv
from bimrobot.assembly.from_ifc import find_storey, frame_scenario, parse_grid
from bimrobot.assembly.planner import plan
from bimrobot.assembly.scenario import load_scenario, run_cells
from bimrobot.cli import main
from bimrobot.coordination.generate import generated_frame
from bimrobot.core.errors import InputError


def _frame(model, storey="Level 1", **kwargs):
    return frame_scenario(model, find_storey(model, storey), **kwargs)


def test_steel_frame_is_a_bay_of_four_columns_and_four_beams(steel_frame_model):
    result = _frame(steel_frame_model)
    sc = result.scenario
    assert result.auto and result.spacing == (2.85, 3.5)  # the frame's column spacing along x and y
    assert [c.type for c in sc.components] == ["column"] * 4 + ["beam"] * 4  # columns first
    assert {result.elements[c.id][2] for c in sc.components} == {
        "Column C1", "Column C2", "Column C3", "Column C4", "Beam B12", "Beam B23", "Beam B43", "Beam B14"}
    # as in the benchmark: columns 4 cells on their foundations, each beam 3 cells between two column tops
    columns = {t.id: t for t in sc.targets if t.type == "column"}
    assert all(t.length == 4 and (t.node1[0], t.node1[1]) in sc.foundations for t in columns.values())
    tops = {t.cells[-1] for t in columns.values()}
    for beam in (t for t in sc.targets if t.type == "beam"):
        cells = beam.cells
        assert beam.length == 3 and cells[0][2] == 4
        before, after = list(cells[0]), list(cells[-1])
        before[beam.axis] -= 1
        after[beam.axis] += 1
        assert tuple(before) in tops and tuple(after) in tops
    # the clip angles (IfcMember) are said to be dropped, with the reason
    assert len(result.dropped) == 8 and all(d.reason.startswith("too short") for d in result.dropped)
    env = AssemblyEnv(scenario=sc)
    env.reset(seed=0)
    best = plan(env)
    assert best.steps <= sc.time_limit and len(best.assignment) == 8


def test_a_coarse_grid_drops_off_grid_columns_and_their_beams(steel_frame_model):
    result = _frame(steel_frame_model, grid=(5.0, 5.0))  # 1.25 m cells: x = 2.846 m lies 0.35 m off a line
    off_grid = sorted(d.name for d in result.dropped if d.reason.startswith("off-grid"))
    assert off_grid == ["Beam B23", "Column C2", "Column C3"]  # the beam runs along y on their grid line
    kept = {result.elements[c.id][2] for c in result.scenario.components}
    assert kept == {"Column C1", "Column C4", "Beam B14"}
    assert sorted(d.name for d in result.dropped if d.reason.startswith("not at a column")) == ["Beam B12", "Beam B43"]


def test_interchangeable_slots_and_the_written_file(steel_frame_ifc, tmp_path, capsys):
    out = tmp_path / "frame.yaml"
    assert main(["assembly", "from-ifc", str(steel_frame_ifc), "--storey", "0", "--interchangeable", "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "kept 4 columns and 4 beams; dropped 8" in printed and "dropped 8 too short" in printed
    assert "solvable: the exact planner completes it in" in printed
    text = out.read_text()
    assert text.startswith("# written by bimrobot") and "IfcColumn 'Column C1'" in text
    sc = load_scenario(out)  # what `bimrobot assembly validate` reads
    assert sc.interchangeable == (("col1", "col2", "col3", "col4"), ("beam1", "beam2", "beam3", "beam4"))
    starts = [cell for c in sc.handled for cell in run_cells(*c.start)]
    assert len(starts) == len(set(starts)) == 28 and all(z == 1 for _, _, z in starts)  # flat in the yard, apart
    assert main(["assembly", "validate", str(out)]) == 0
    capsys.readouterr()
    # the benchmark's reference returns for it: the planner's optimum, and a random policy that places nothing
    assert main(["assembly", "optimum", "--scenario", str(out), "--episodes", "2"]) == 0
    row = capsys.readouterr().out.splitlines()[1].split()
    optimal, random = float(row[-4]), float(row[-2])
    assert optimal > 0 and -15 - 2 * (sc.time_limit - 15) <= random < -700  # never placing anything: -785


def test_bad_requests_are_one_sentence_and_write_nothing(steel_frame_ifc, steel_frame_model, tmp_path, capsys):
    out = tmp_path / "s.yaml"
    assert main(["assembly", "from-ifc", str(steel_frame_ifc), "--storey", "Roof", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no such storey" in err and "0 'Level 1' (0 m); 1 'Level 2' (4.025 m)" in err and err.count("\n") == 1
    assert not out.exists()
    with pytest.raises(InputError, match="storey 'Level 2' .* has no vertical columns .* storeys with IfcColumns: 'Level 1' \\(4\\)"):
        _frame(steel_frame_model, "Level 2")
    with pytest.raises(InputError, match="spans 77 x 5 cells .* more than the env's 64 cells per axis; try a larger --grid"):
        _frame(generated_frame(nx=20, ny=2))  # 19 bays of 4 cells in a row
    with pytest.raises(InputError, match="has 48 columns and 82 beams on the grid, 130 components; a scenario holds at most 100"):
        _frame(generated_frame(nx=8, ny=6))
    with pytest.raises(InputError, match="--grid must be 'auto'"):
        parse_grid("six")
    assert parse_grid("6x7.2") == (6.0, 7.2) and parse_grid("auto") is None


def test_shared_steel_model_ground_floor(shared_ifc):
    """ROOT-staal (the Schependomlaan architect's steel, an .ifczip): its ground floor's four posts and
    the two angles between them; the fifth column stands 0.6 m higher and is said to be dropped."""
    from bimrobot.bim import load_model

    model = load_model(shared_ifc("ROOT-staal.ifczip"), include="IfcColumn, IfcBeam, IfcMember", properties=False)
    result = _frame(model, "00 begane grond")
    kinds = [c.type for c in result.scenario.components]
    assert kinds.count("column") == 4 and kinds.count("beam") == 2
    assert [d.name for d in result.dropped if d.reason.startswith("off the storey's base")] == ["K152,4/12,5"]
    env = AssemblyEnv(scenario=result.scenario)
    env.reset(seed=0)
    assert plan(env).steps <= result.scenario.time_limit
