"""The benchmark's output folder: marked as an ``rl benchmark`` (:data:`BENCHMARK_KIND`), continued when
it is one (finished runs are reused), created or replaced under :mod:`bimrobot.core.io`'s policy
otherwise, and removed again when the benchmark fails before its first run finishes
(:func:`benchmark_folder`). The folder stays in place while the grid runs, so that an interrupted
benchmark continues where it stopped.
"""

from __future__ import annotations

import contextlib
import json
import shutil
import sys
import time
import uuid
from pathlib import Path
from typing import Iterator

from bimrobot.core.errors import InputError
from bimrobot.core.io import MARKER, check_output, describe_folder

BENCHMARK_KIND = "rl benchmark"
_LEGACY_HEADING = "# Assembly-planning benchmark results"


def _marker_kind(folder: Path) -> str | None:
    try:
        return json.loads((folder / MARKER).read_text(encoding="utf-8")).get("kind")
    except (OSError, ValueError, AttributeError):
        return None


def _is_legacy_benchmark(folder: Path) -> bool:
    """A benchmark folder written before output folders carried :data:`bimrobot.core.io.MARKER`: its grid.json
    (with a spec and runs) and a table.md under the benchmark's own heading."""
    try:
        grid = json.loads((folder / "grid.json").read_text(encoding="utf-8"))
        with open(folder / "table.md", encoding="utf-8") as handle:
            head = [handle.readline().rstrip("\n") for _ in range(2)]
    except (OSError, ValueError):
        return False
    return isinstance(grid, dict) and "spec" in grid and "runs" in grid and _LEGACY_HEADING in head


def _existing_benchmark(out: str | Path, option: str) -> Path | None:
    """The resolved folder when ``out`` is a benchmark folder bimrobot wrote (to be continued), else None.
    The current directory is refused even then, as everywhere."""
    path = Path(out).resolve()
    if not path.is_dir():
        return None
    if (path / MARKER).is_file():
        if _marker_kind(path) != BENCHMARK_KIND:
            return None
    elif not _is_legacy_benchmark(path):
        return None
    cwd = Path.cwd().resolve()
    if cwd == path or path in cwd.parents:
        check_output(out, folder=True, option=option)  # raises: the current directory
    return path


def _finished_runs(folder: Path) -> list[Path]:
    runs = folder / "runs"
    return [run for run in runs.iterdir() if (run / "results.json").is_file()] if runs.is_dir() else []


def _write_marker(folder: Path) -> None:
    from bimrobot import __version__

    marker = {"kind": BENCHMARK_KIND, "inputs": [], "bimrobot": __version__,
              "written": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    (folder / MARKER).write_text(json.dumps(marker, indent=2), encoding="utf-8")


@contextlib.contextmanager
def benchmark_folder(out: str | Path, *, option: str = "-o", create: bool = True) -> Iterator[Path]:
    """The benchmark's output folder (resolved), under :mod:`bimrobot.core.io`'s policy adapted to a folder that
    grows run by run and must survive an interruption so that the grid can be resumed.

    * a benchmark folder bimrobot wrote (its marker says ``"rl benchmark"``, or it has the grid.json and
      table.md of a benchmark from before markers) is continued: its finished runs of this grid are reused
      and the summary rewritten; one line on stderr says so;
    * a new or empty folder is created and marked at once;
    * another folder bimrobot wrote (a ``simulate`` output, a run dir, ...) is replaced, saying so: it is
      moved aside at once, put back if the benchmark fails before its first run finishes, deleted otherwise;
    * everything :func:`bimrobot.core.io.check_output` refuses is refused (the current directory, a file, a
      non-empty folder bimrobot did not write, a path under a file, a symlink to any of those).

    If the benchmark fails or is interrupted before any run has finished, what this call created is
    removed (no empty output folder is left). With ``create=False`` (``--summary-only``) only an existing
    benchmark folder is accepted.
    """
    path = Path(out)
    folder = _existing_benchmark(path, option)
    if folder is not None:
        if not (folder / MARKER).is_file():
            _write_marker(folder)  # a benchmark folder from before markers: bimrobot's, now marked
        if create:
            finished = len(_finished_runs(folder))
            print(f"bimrobot: continuing the benchmark in {path} ({finished} finished run{'' if finished == 1 else 's'}); "
                  "finished runs of this grid are reused and the summary is rewritten", file=sys.stderr)
        yield folder
        return
    replaced = check_output(path, folder=True, option=option)
    if not create:
        raise InputError(f"{path / 'runs'} holds no finished run of this grid")
    folder = path.resolve()
    backup = None
    if replaced is not None:
        print(f"bimrobot: replacing {path} ({describe_folder(replaced)}) with a benchmark folder", file=sys.stderr)
        backup = folder.with_name(f".{folder.name}.{uuid.uuid4().hex[:8]}.old")
        folder.rename(backup)
    created = [node for node in (folder, *folder.parents) if not node.exists()]
    try:
        folder.mkdir(parents=True, exist_ok=True)
        _write_marker(folder)
        (folder / "runs").mkdir(exist_ok=True)
    except OSError as exc:
        for node in created:
            shutil.rmtree(node, ignore_errors=True) if node == folder else _rmdir_quietly(node)
        if backup is not None:
            backup.rename(folder)
        raise InputError(f"{option} {path}: cannot write there ({exc.strerror})") from None
    try:
        yield folder
    except BaseException:
        if not _finished_runs(folder):
            _undo(folder, created, backup)
            backup = None
        raise
    finally:
        if backup is not None:
            shutil.rmtree(backup, ignore_errors=True)


def _rmdir_quietly(folder: Path) -> None:
    try:
        folder.rmdir()
    except OSError:
        pass


def _undo(folder: Path, created: list[Path], backup: Path | None) -> None:
    """Remove what :func:`benchmark_folder` made of ``folder`` (no run finished), and put back what it replaced."""
    if folder in created or backup is not None:
        shutil.rmtree(folder, ignore_errors=True)
    else:  # a folder that was empty before: empty again
        shutil.rmtree(folder / "runs", ignore_errors=True)
        (folder / MARKER).unlink(missing_ok=True)
    for node in created:
        if node != folder:
            _rmdir_quietly(node)
    if backup is not None:
        backup.rename(folder)
