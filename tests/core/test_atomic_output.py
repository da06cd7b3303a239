"""Atomic output: nothing half-written on failure, normal permissions on success."""

import os
import stat

import pytest

from bimrobot.io import atomic_output_dir, atomic_output_file


def test_failed_run_leaves_no_directory(tmp_path):
    target = tmp_path / "pkg"
    with pytest.raises(RuntimeError):
        with atomic_output_dir(target) as tmp:
            (tmp / "half.sdf").write_text("<sdf")
            raise RuntimeError("conversion failed")
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []


def test_successful_run_replaces_the_old_output(tmp_path):
    target = tmp_path / "pkg"
    target.mkdir()
    (target / "old.txt").write_text("old")
    with atomic_output_dir(target) as tmp:
        (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in target.iterdir()) == ["new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pkg"]


def test_outputs_get_the_umask_permissions_not_owner_only(tmp_path):
    old = os.umask(0o022)
    try:
        with atomic_output_dir(tmp_path / "pkg") as tmp:
            (tmp / "a.txt").write_text("x")
        with atomic_output_file(tmp_path / "table.json") as tmp_file:
            tmp_file.write_text("{}")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "pkg").stat().st_mode) == 0o755
    assert stat.S_IMODE((tmp_path / "table.json").stat().st_mode) == 0o644


def test_failed_file_write_keeps_the_previous_file(tmp_path):
    target = tmp_path / "table.json"
    target.write_text("previous")
    with pytest.raises(ValueError):
        with atomic_output_file(target) as tmp_file:
            tmp_file.write_text("partial")
            raise ValueError("bad row")
    assert target.read_text() == "previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.json"]
