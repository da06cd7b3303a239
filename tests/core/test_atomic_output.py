"""The output policy (bimrobot.core.io): what is refused, what is replaced, and that failures leave nothing."""

import hashlib
import json
import os
import stat
from pathlib import Path

import pytest

from bimrobot.core.errors import InputError
from bimrobot.core.io import MARKER, atomic_output_dir, atomic_output_file, check_output, signature
from output_checks import snapshot


def _write_ours(target: Path, text: str = "new", kind: str = "test") -> None:
    with atomic_output_dir(target, kind=kind, inputs=[]) as tmp:
        (tmp / "result.txt").write_text(text)
        (tmp / "meshes").mkdir()
        (tmp / "meshes" / "a.stl").write_bytes(b"solid a")


def test_failed_run_leaves_no_directory_and_no_parents_it_created(tmp_path):
    target = tmp_path / "a" / "b" / "pkg"
    with pytest.raises(RuntimeError):
        with atomic_output_dir(target, kind="test") as tmp:
            (tmp / "half.sdf").write_text("<sdf")
            raise RuntimeError("conversion failed")
    assert list(tmp_path.iterdir()) == []


def test_a_folder_bimrobot_wrote_is_replaced_and_the_replacement_is_announced(tmp_path, capsys):
    model = tmp_path / "model.ifc"
    model.write_text("ISO-10303-21;")
    target = tmp_path / "out"
    _write_ours(target, "first", kind="simulate")
    with atomic_output_dir(target, kind="simulate", inputs=[model]) as tmp:
        (tmp / "result.txt").write_text("second")
    assert (target / "result.txt").read_text() == "second"
    marker = json.loads((target / MARKER).read_text())
    assert marker["kind"] == "simulate" and marker["inputs"] == [str(model.resolve())]
    assert marker["files"] == {"result.txt": {"size": 6, "sha256": hashlib.sha256(b"second").hexdigest()}}
    assert "replacing" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.ifc", "out"]  # no backup or temp left


@pytest.mark.parametrize("case", ["dot", "input", "parent_of_input", "foreign_folder", "symlink_to_foreign", "under_a_file"])
def test_refused_targets_are_left_byte_for_byte(tmp_path, monkeypatch, case):
    project = tmp_path / "project"
    project.mkdir()
    model = project / "model.ifc"
    model.write_bytes(b"ISO-10303-21; my model")
    (project / "notes.txt").write_text("mine")
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "thesis.docx").write_bytes(b"\x00important")
    (tmp_path / "link").symlink_to(foreign)
    monkeypatch.chdir(project)
    target = {
        "dot": ".", "input": "model.ifc", "parent_of_input": str(project), "foreign_folder": str(foreign),
        "symlink_to_foreign": str(tmp_path / "link"), "under_a_file": "notes.txt/out",
    }[case]
    before = snapshot(tmp_path)
    with pytest.raises(InputError) as error:
        with atomic_output_dir(target, kind="test", inputs=[model]) as tmp:
            (tmp / "x").write_text("x")
    assert "\n" not in str(error.value)
    assert snapshot(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["foreign", "link", "project"]


def test_a_foreign_file_is_refused_and_a_signed_one_replaced(tmp_path):
    foreign = tmp_path / "report.json"
    foreign.write_text('{"mine": true}')
    with pytest.raises(InputError, match="did not write"):
        check_output(foreign, folder=False)
    ours = tmp_path / "ours.json"
    for value in (1, 2):
        with atomic_output_file(ours) as tmp:
            tmp.write_text(json.dumps({"generator": signature("test"), "value": value}))
    assert json.loads(ours.read_text())["value"] == 2
    assert foreign.read_text() == '{"mine": true}'


def test_a_writer_that_forgets_the_signature_is_a_bug_not_a_silent_file(tmp_path):
    with pytest.raises(RuntimeError, match="signature"):
        with atomic_output_file(tmp_path / "x.json") as tmp:
            tmp.write_text("{}")
    assert list(tmp_path.iterdir()) == []


def test_folder_where_a_file_is_wanted_and_the_reverse(tmp_path):
    (tmp_path / "dir").mkdir()
    (tmp_path / "file.txt").write_text("x")
    with pytest.raises(InputError, match="is a folder"):
        check_output(tmp_path / "dir", folder=False)
    with pytest.raises(InputError, match="not a folder"):
        check_output(tmp_path / "file.txt", folder=True)


def test_an_empty_folder_may_be_used(tmp_path):
    (tmp_path / "empty").mkdir()
    _write_ours(tmp_path / "empty")
    assert (tmp_path / "empty" / "result.txt").read_text() == "new"


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into read-only folders")
def test_an_unwritable_folder_is_one_sentence(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        with pytest.raises(InputError, match="not writable"):
            check_output(locked / "out", folder=True)
    finally:
        locked.chmod(0o700)


def test_a_path_on_a_read_only_filesystem_is_one_sentence():
    # /proc refuses new entries even to root: the 'unwritable path' case on any Linux machine.
    with pytest.raises(InputError, match="cannot write there|not writable"):
        with atomic_output_dir("/proc/bimrobot-test-out", kind="test") as tmp:
            (tmp / "x").write_text("x")


def test_outputs_get_the_umask_permissions_not_owner_only(tmp_path):
    old = os.umask(0o022)
    try:
        _write_ours(tmp_path / "pkg")
        with atomic_output_file(tmp_path / "table.json") as tmp_file:
            tmp_file.write_text(json.dumps({"generator": signature()}))
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "pkg").stat().st_mode) == 0o755
    assert stat.S_IMODE((tmp_path / "table.json").stat().st_mode) == 0o644


def test_failed_file_write_keeps_the_previous_file(tmp_path):
    target = tmp_path / "table.json"
    target.write_text(json.dumps({"generator": signature(), "rows": 1}))
    previous = target.read_bytes()
    with pytest.raises(ValueError):
        with atomic_output_file(target) as tmp_file:
            tmp_file.write_text("partial")
            raise ValueError("bad row")
    assert target.read_bytes() == previous
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.json"]


def test_control_characters_in_a_path_are_escaped_in_the_message(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "evil\x1b[31m").mkdir()
    (tmp_path / "evil\x1b[31m" / "f").write_text("x")
    with pytest.raises(InputError) as error:
        check_output("evil\x1b[31m", folder=True)
    assert "\x1b" not in str(error.value) and "\\x1b" in str(error.value)


def _refused_unchanged(target: Path, match: str, kind: str = "test") -> str:
    """Writing ``kind`` into ``target`` is refused with one sentence matching ``match``; nothing changes."""
    before = snapshot(target.parent)
    with pytest.raises(InputError, match=match) as error:
        with atomic_output_dir(target, kind=kind) as tmp:
            (tmp / "result.txt").write_text("replacement")
    assert "\n" not in str(error.value)
    assert snapshot(target.parent) == before
    return str(error.value)


@pytest.mark.parametrize("change", ["added", "added_in_a_subfolder", "added_empty_folder", "changed_same_size",
                                    "removed", "truncated", "symlink_added"])
def test_a_folder_bimrobot_wrote_and_the_user_changed_since_is_refused_naming_the_file(tmp_path, change):
    target = tmp_path / "out"
    _write_ours(target)
    if change == "added":
        (target / "notes.txt").write_text("mine")
        named = "'notes.txt' (added)"
    elif change == "added_in_a_subfolder":
        (target / "meshes" / "mine.stl").write_text("mine")
        named = "'meshes/mine.stl' (added)"
    elif change == "added_empty_folder":
        (target / "drafts").mkdir()
        named = "'drafts' (added)"
    elif change == "changed_same_size":
        (target / "result.txt").write_text("NEW")  # same size, other bytes: the hash tells
        named = "'result.txt' (changed)"
    elif change == "removed":
        (target / "meshes" / "a.stl").unlink()
        named = "'meshes/a.stl' (removed)"
    elif change == "truncated":
        (target / "result.txt").write_text("")
        named = "'result.txt' (changed)"
    else:
        (target / "link").symlink_to(tmp_path)
        named = "'link' (added)"
    message = _refused_unchanged(target, "was changed since")
    assert named in message and "delete it yourself" in message and "another folder" in message


def test_the_refusal_names_three_foreign_files_and_counts_the_rest(tmp_path):
    target = tmp_path / "out"
    _write_ours(target)
    for n in range(5):
        (target / f"mine{n}.txt").write_text("mine")
    message = _refused_unchanged(target, "was changed since")
    assert "'mine0.txt' (added), 'mine1.txt' (added), 'mine2.txt' (added) and 2 more" in message


def test_a_folder_of_another_kind_is_refused(tmp_path):
    target = tmp_path / "out"
    _write_ours(target, kind="simulate")
    message = _refused_unchanged(target, "not a split output", kind="split")
    assert "holds a simulate output of no input file" in message


def test_a_marker_without_a_manifest_is_refused(tmp_path):
    """A folder marked before markers listed their files (or a folder that grows, as a benchmark's):
    what in it is the user's cannot be told, so it is not deleted."""
    target = tmp_path / "out"
    target.mkdir()
    (target / MARKER).write_text(json.dumps({"kind": "test", "inputs": [], "written": "yesterday"}))
    (target / "thesis.docx").write_bytes(b"my only copy")
    _refused_unchanged(target, "does not list its files")


def test_a_file_added_while_the_work_runs_is_not_lost(tmp_path):
    """The check before the work passes; a file the user adds during the work is found when the old
    folder is moved aside, and everything is put back."""
    target = tmp_path / "out"
    _write_ours(target)
    with pytest.raises(InputError, match="'late.txt' \\(added\\)"):
        with atomic_output_dir(target, kind="test") as tmp:
            (tmp / "result.txt").write_text("replacement")
            (target / "late.txt").write_text("written during the run")
    assert (target / "late.txt").read_text() == "written during the run"
    assert (target / "result.txt").read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no temporary or backup left


def test_an_unchanged_folder_copied_elsewhere_is_still_replaced(tmp_path, capsys):
    """The manifest holds sizes and hashes, not times: a copy (new mtimes) of an output is still bimrobot's."""
    import shutil

    _write_ours(tmp_path / "out")
    shutil.copytree(tmp_path / "out", tmp_path / "copy")
    _write_ours(tmp_path / "copy", "second")
    assert (tmp_path / "copy" / "result.txt").read_text() == "second"
    assert "bimrobot: replacing " in capsys.readouterr().err


def test_an_oxigraph_store_queried_since_is_still_bimrobots_but_a_file_added_to_it_is_not(tmp_path, capsys):
    """Opening a RocksDB store rewrites its own files (kind 'graph (Oxigraph store)'): those are not the
    user's; a notes file put into the store folder is."""
    ox = pytest.importorskip("pyoxigraph")
    kind = "graph (Oxigraph store)"

    def write_store(target: Path) -> None:
        with atomic_output_dir(target, kind=kind) as tmp:
            store = ox.Store(str(tmp))
            store.add(ox.Quad(ox.NamedNode("http://x/a"), ox.NamedNode("http://x/b"), ox.Literal("c")))
            store.flush()
            del store

    target = tmp_path / "store"
    write_store(target)
    store = ox.Store(str(target))  # as `bimrobot query` does
    assert len(list(store.query("SELECT * WHERE { ?s ?p ?o }"))) == 1
    del store
    write_store(target)
    assert "bimrobot: replacing " in capsys.readouterr().err
    (target / "notes.txt").write_text("mine")
    _refused_unchanged(target, "'notes.txt' \\(added\\)", kind=kind)


def test_the_marker_lists_the_bytes_on_disk_whether_written_with_noted_digests_or_not(tmp_path):
    """Files written through bimrobot.core.written are not read back for the marker; one rewritten
    after its digest was noted (another size) is hashed anew, and a package replaced later is checked
    against the true digests."""
    from bimrobot.core import written

    target = tmp_path / "out"
    with atomic_output_dir(target, kind="test") as tmp:
        (tmp / "meshes").mkdir()
        written.write_text(tmp / "meshes" / "a.dae", "<COLLADA/>\n")
        written.write_bytes(tmp / "b.stl", b"solid b")
        written.write_text(tmp / "c.sdf", "<sdf/>")
        (tmp / "c.sdf").write_text("<sdf version='1.9'/>")  # changed after the note
        (tmp / "d.txt").write_text("not noted")
    listed = json.loads((target / MARKER).read_text())["files"]
    assert set(listed) == {"meshes", "b.stl", "c.sdf", "d.txt", "meshes/a.dae"}
    for name, entry in listed.items():
        if "sha256" in entry:
            data = (target / name).read_bytes()
            assert entry == {"size": len(data), "sha256": hashlib.sha256(data).hexdigest()}, name
    assert not [p for p in written.take_notes() if p.startswith(str(tmp))]  # spent notes are dropped
    _write_ours(target, "second")  # the true digests: the folder is still bimrobot's, and replaced
    assert (target / "result.txt").read_text() == "second"
