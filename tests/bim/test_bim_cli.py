"""The bim sub-commands as a user runs them: exit codes, messages, outputs."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from bimrobot.cli import main


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bimrobot", *args], capture_output=True, text=True, timeout=300)


def test_example_then_inspect_json(tmp_path, capsys):
    path = tmp_path / "frame.ifc"
    assert main(["example", "steel-frame", "-o", str(path)]) == 0
    capsys.readouterr()
    assert main(["inspect", str(path), "--json", "--infer-connections"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["schema"] == "IFC4"
    assert summary["classes"]["IfcColumn"] == {"count": 4, "weight_kg": pytest.approx(4 * 289.81), "weights_missing": 0}
    assert summary["connections"] == {"count": 24, "types": {"BOLTED": 24}}
    assert summary["weights"]["missing"] == 0
    assert [s["name"] for s in summary["storeys"]] == ["Level 1", "Level 2"]
    assert summary["inferred_connections"]["count"] >= 24


def test_inspect_table_on_ifc_unit(shared_ifc, capsys):
    assert main(["inspect", str(shared_ifc("ifcUnit.ifc"))]) == 0
    out = capsys.readouterr().out
    assert "length MILLIMETRE (x0.001 -> m)" in out
    assert "connections (IfcRelConnectsWithRealizingElements): 36" in out
    assert "4 x IfcFastener: curve-only geometry" in out
    assert "weights: 16 found, 48 missing, 0 suspect" in out  # 4 base plates of "Metal Stud Layer": unknown


def test_split_cli(tmp_path, capsys):
    path = tmp_path / "gh.ifc"
    main(["example", "greenhouse", "-o", str(path)])
    assert main(["split", str(path), "-o", str(tmp_path / "parts"), "--include", "IfcColumn"]) == 0
    assert "wrote 9 IFC files" in capsys.readouterr().out
    assert len(list((tmp_path / "parts").glob("*.ifc"))) == 9


@pytest.mark.parametrize(
    "content, message",
    [
        (None, "no such file"),
        ("hello", "is not an IFC file"),
        ("ISO-10303-21;\nHEADER;\nFILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n#1=IFCWALL(", "is truncated"),
        ("ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\nFILE_NAME('','',(''),(''),'','','');\n"
         "FILE_SCHEMA(('IFC4X3_RC2'));\nENDSEC;\nDATA;\nENDSEC;\nEND-ISO-10303-21;\n", "unsupported IFC schema IFC4X3_RC2"),
        # a stray character on line 8: the line is named (IfcOpenShell itself says only "check logs")
        ("ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\nFILE_NAME('','',(''),(''),'','','');\n"
         "FILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n#1=IFCPERSON($,$,@,$,$,$,$);\nENDSEC;\nEND-ISO-10303-21;\n",
         "could not be parsed as IFC: syntax error: token @ at offset 143 invalid valid token (line 8)"),
    ],
)
@pytest.mark.parametrize("command", ["inspect", "split"])
def test_bad_input_exit_2_with_one_sentence_naming_the_file(tmp_path, capsys, content, message, command):
    path = tmp_path / "input.ifc"
    if content is not None:
        path.write_text(content)
    args = [command, str(path)] + (["-o", str(tmp_path / "out")] if command == "split" else [])
    assert main(args) == 2
    stderr = capsys.readouterr().err
    assert message in stderr
    assert str(path) in stderr
    assert len(stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == (["input.ifc"] if content is not None else [])


def test_bad_input_exit_status_of_the_installed_command(tmp_path):
    """The real process: exit status 2 and the one-sentence message on stderr."""
    path = tmp_path / "gh.ifc"
    main(["example", "greenhouse", "-o", str(path)])
    result = run_cli("inspect", str(path), "--include", "IfcBeem")
    assert result.returncode == 2
    assert result.stderr.strip() == (
        f"bimrobot inspect: error: {path}: --include names 'IfcBeem', which is not an IFC4 class "
        "(this model's element classes: IfcBeam, IfcColumn, IfcFooting)"
    )


def test_inspect_and_split_take_include_and_exclude_together(tmp_path, capsys, steel_frame_ifc):
    selector = ["--include", "IfcElement", "--exclude", "IfcMechanicalFastener, IfcFooting"]
    assert main(["split", str(steel_frame_ifc), "-o", str(tmp_path / "parts"), *selector]) == 0
    assert "wrote 20 IFC files" in capsys.readouterr().out  # 4 columns, 4 beams, 4 plates, 8 clip angles
    assert main(["inspect", str(steel_frame_ifc), "--json", *selector]) == 0
    assert json.loads(capsys.readouterr().out)["elements"] == 20


def test_inspect_reads_an_ifczip(shared_ifc, capsys):
    assert main(["inspect", str(shared_ifc("ROOT-staal.ifczip")), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["schema"] == "IFC2X3" and summary["elements"] > 0


def test_example_writes_a_file_it_recognises_and_replaces_only_that(tmp_path, capsys, monkeypatch):
    from bimrobot.core import io

    monkeypatch.chdir(tmp_path)
    assert main(["example", "steel-frame", "-o", "frame.ifc"]) == 0
    assert io.has_signature(tmp_path / "frame.ifc")
    capsys.readouterr()
    assert main(["example", "greenhouse", "-o", "frame.ifc"]) == 0  # bimrobot's own file: replaced, said once
    err = capsys.readouterr().err
    assert err.strip().splitlines() == ["bimrobot: replacing frame.ifc (a file bimrobot wrote)"]
    assert "Chapter 3 light steel frame" in (tmp_path / "frame.ifc").read_text()
    (tmp_path / "mine.ifc").write_bytes(b"ISO-10303-21;\n/* the user's model */\n")
    (tmp_path / "folder").mkdir()
    for target, message in [
        ("mine.ifc", "is an existing file that bimrobot did not write"),
        ("folder", "is a folder; give a file name"),
        ("mine.ifc/x.ifc", "is a file, not a folder"),
    ]:
        assert main(["example", "greenhouse", "-o", target]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1
    assert (tmp_path / "mine.ifc").read_bytes() == b"ISO-10303-21;\n/* the user's model */\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder", "frame.ifc", "mine.ifc"]
