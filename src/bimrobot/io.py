"""The one output policy: every file or folder bimrobot writes goes through this module.

Rule (checked before the work starts and again when the result is put in place):

* refused, with one sentence (an :class:`~bimrobot.errors.InputError`, exit 2): the current directory
  or a folder that contains it, an input file, a folder that contains an input, an existing file or a
  non-empty folder that bimrobot did not write, a file where a folder is wanted (and the reverse), a
  path under a regular file, and a path whose folder cannot be written; a symlink is judged by what it
  points at;
* replaced, saying so in one line on stderr: a folder bimrobot wrote (it holds :data:`MARKER`) or a
  file bimrobot wrote (it carries :data:`SIGNATURE`, or a kind-specific recogniser says so);
* written atomically: into a temporary sibling that is renamed into place at the end. On any failure
  the temporary sibling and any parent folder the run created are removed, so nothing is left behind.

Writers of single files put :data:`SIGNATURE` in the file's first 64 KiB (a comment, a JSON key, a PNG
text chunk, ...): that is how a later run knows the file is bimrobot's to replace.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import os
import shutil
import sys
import tempfile
import uuid
from pathlib import Path
from typing import Callable, Iterable, Iterator

from bimrobot import __version__
from bimrobot.errors import InputError

#: The file that marks a folder as written by bimrobot (JSON: kind, inputs, version, time).
MARKER = ".bimrobot-output.json"

#: Text every single file written by bimrobot carries near its start.
SIGNATURE = "written by bimrobot"

#: How far into a file :data:`SIGNATURE` is looked for (bytes).
SIGNATURE_WINDOW = 65536

Recogniser = Callable[[Path], bool]


def signature(what: str = "") -> str:
    """The signature line for a file header, e.g. ``written by bimrobot 0.1.0 (rcan run report)``."""
    return f"{SIGNATURE} {__version__}" + (f" ({what})" if what else "")


def has_signature(path: Path) -> bool:
    """True when :data:`SIGNATURE` occurs in the first :data:`SIGNATURE_WINDOW` bytes of ``path``."""
    try:
        with open(path, "rb") as stream:
            return SIGNATURE.encode() in stream.read(SIGNATURE_WINDOW)
    except OSError:
        return False


def printable(text: str) -> str:
    """``text`` with every non-printable character (control characters, line breaks, odd spaces) written
    as a Python escape (``\\x01``, ``\\n``, ``\\u2028``): safe for a terminal line, a log, an XML text
    node or attribute (XML 1.0 cannot hold most control characters even escaped). Letters of any
    script are kept."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else c.encode("unicode_escape", "backslashreplace").decode("ascii") for c in text)


def _display(path: str | os.PathLike) -> str:
    """A path as the user gave it, with control characters escaped (they never reach the terminal raw)."""
    return printable(os.fspath(path))


def _is_within(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def _resolved_inputs(inputs: Iterable) -> list[Path]:
    resolved = []
    for item in inputs:
        if item is None:
            continue
        text = os.fspath(item)
        if not text or text == ":memory:" or "://" in text or text.startswith("generated:"):
            continue
        resolved.append(Path(text).resolve())
    return resolved


def _check_parent(target: Path, option: str, shown: str) -> None:
    """Refuse a path under a regular file or in a folder that cannot be written."""
    ancestor = target.parent
    while not ancestor.exists():
        if ancestor.is_symlink():
            raise InputError(f"{option} {shown}: {_display(ancestor)} is a broken symbolic link")
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise InputError(f"{option} {shown}: {_display(ancestor)} is a file, not a folder, so nothing can be written under it")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise InputError(f"{option} {shown}: the folder {_display(ancestor)} is not writable")


def describe_folder(folder: Path) -> str:
    """What a bimrobot output folder holds, from its marker: e.g. ``simulate output of frame.ifc``."""
    try:
        marker = json.loads((folder / MARKER).read_text(encoding="utf-8"))
        inputs = ", ".join(Path(p).name for p in marker.get("inputs", [])) or "no input file"
        return f"{marker.get('kind', 'bimrobot')} output of {inputs}, written {marker.get('written', 'earlier')}"
    except (OSError, ValueError, AttributeError):
        return "bimrobot output"


def check_output(
    target: str | os.PathLike,
    *,
    folder: bool,
    inputs: Iterable = (),
    option: str = "-o",
    recognise: Recogniser = has_signature,
) -> Path | None:
    """Apply the output policy to ``target``; return the resolved path of what would be replaced, or None.

    ``folder``: the output is a folder (else a file). ``inputs``: the files the command reads (paths;
    None, ``:memory:``, URLs and ``generated:`` specs are ignored). ``option``: how the user named the
    path, for the message. ``recognise``: for file outputs, tells whether an existing file is bimrobot's.
    Raises InputError when the policy refuses the path.
    """
    shown = _display(target)
    if not os.fspath(target):
        raise InputError(f"{option}: the path is empty")
    path = Path(target).resolve()
    cwd = Path.cwd().resolve()
    if _is_within(cwd, path):
        what = "the current directory" if path == cwd else "a folder that contains the current directory"
        example = "out/" if folder else "out/result" + (Path(shown).suffix or ".json")
        raise InputError(f"{option} {shown} is {what}; give a new {'folder' if folder else 'file'}, e.g. {option} {example}")
    for source in _resolved_inputs(inputs):
        if path == source:
            raise InputError(f"{option} {shown} is an input of this command ({_display(source)}); give another path")
        if folder and _is_within(source, path):
            raise InputError(f"{option} {shown} contains an input of this command ({_display(source)}); give another folder")
    _check_parent(path, option, shown)
    if not path.exists():
        if path.is_symlink():
            raise InputError(f"{option} {shown} is a broken symbolic link")
        return None
    if folder:
        if not path.is_dir():
            raise InputError(f"{option} {shown} is an existing file, not a folder; give a folder")
        if (path / MARKER).is_file():
            return path
        if any(path.iterdir()):
            raise InputError(
                f"{option} {shown} is a folder that bimrobot did not write and it is not empty; "
                "give a new or empty folder (nothing was changed)"
            )
        return None
    if path.is_dir():
        raise InputError(f"{option} {shown} is a folder; give a file name")
    if not path.is_file():
        raise InputError(f"{option} {shown} is not a regular file (a device or a pipe); give a file name")
    if not recognise(path):
        raise InputError(f"{option} {shown} is an existing file that bimrobot did not write; give a new file name (nothing was changed)")
    return path


def _announce(target: str | os.PathLike, replaced: Path, folder: bool, inputs: list[Path]) -> None:
    if folder:
        what = describe_folder(replaced)
    else:
        what = "a file bimrobot wrote"
    source = f"; the new one is from {', '.join(p.name for p in inputs)}" if inputs else ""
    print(f"bimrobot: replacing {_display(target)} ({what}){source}", file=sys.stderr)


def _apply_umask(path: Path, mode: int) -> None:
    """Give ``path`` the permissions a normal create would (mkdtemp/mkstemp make them owner-only)."""
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(path, mode & ~mask)


def _make_parents(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; return the ones created, deepest first.

    On an OSError the ones already made are removed before it is raised.
    """
    missing = []
    node = folder
    while not node.exists():
        missing.append(node)
        node = node.parent
    created: list[Path] = []
    try:
        for node in reversed(missing):
            node.mkdir()
            created.insert(0, node)
    except OSError:
        _remove_empty(created)
        raise
    return created


def _remove_empty(folders: list[Path]) -> None:
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:
            break


def _marker(kind: str, inputs: list[Path]) -> str:
    return json.dumps(
        {
            "kind": kind,
            "inputs": [str(p) for p in inputs],
            "bimrobot": __version__,
            "written": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        },
        indent=2,
    )


@contextlib.contextmanager
def atomic_output_dir(
    target: str | os.PathLike, *, kind: str, inputs: Iterable = (), option: str = "-o"
) -> Iterator[Path]:
    """Yield a temporary folder next to ``target``; on success it becomes ``target``.

    ``kind`` names the output (``"simulate"``, ``"convert"``, ...) in the folder's marker. The policy
    (:func:`check_output`) is applied before the work starts and again before the rename. On any
    exception the temporary folder and the parents this call created are removed.
    """
    inputs = _resolved_inputs(inputs)
    check_output(target, folder=True, inputs=inputs, option=option)
    path = Path(target).resolve()
    created: list[Path] = []
    try:
        created = _make_parents(path.parent)
        tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
    except OSError as exc:
        _remove_empty(created)
        raise InputError(f"{option} {_display(target)}: cannot write there ({exc.strerror})") from None
    _apply_umask(tmp, 0o777)
    try:
        yield tmp
        _finish_folder(tmp, target, kind=kind, inputs=inputs, option=option)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        _remove_empty(created)
        raise


def _finish_folder(tmp: Path, target: str | os.PathLike, *, kind: str, inputs: list[Path], option: str) -> None:
    """Mark the finished folder ``tmp`` as bimrobot's, check ``target`` again (it may have changed during
    the work) and put ``tmp`` in its place, announcing what it replaces."""
    (tmp / MARKER).write_text(_marker(kind, inputs), encoding="utf-8")
    replaced = check_output(target, folder=True, inputs=inputs, option=option)
    if replaced is not None:
        _announce(target, replaced, True, inputs)
    _put_folder_in_place(tmp, Path(target).resolve())


def _put_folder_in_place(tmp: Path, path: Path) -> None:
    """Rename ``tmp`` onto ``path``; an existing ``path`` (checked to be ours or empty) goes away after."""
    if not path.exists():
        tmp.rename(path)
        return
    backup = path.with_name(f".{path.name}.{uuid.uuid4().hex[:8]}.old")
    path.rename(backup)
    try:
        tmp.rename(path)
    except BaseException:
        backup.rename(path)
        raise
    shutil.rmtree(backup, ignore_errors=True)


@contextlib.contextmanager
def atomic_output_file(
    target: str | os.PathLike,
    *,
    inputs: Iterable = (),
    option: str = "-o",
    recognise: Recogniser = has_signature,
) -> Iterator[Path]:
    """Yield a temporary file path next to ``target``; on success it is renamed onto ``target``.

    The written file must be recognisable as bimrobot's (``recognise``, by default :data:`SIGNATURE`
    near its start) so that a later run may replace it; a writer that forgets is a bug and raises.
    """
    inputs = _resolved_inputs(inputs)
    check_output(target, folder=False, inputs=inputs, option=option, recognise=recognise)
    path = Path(target).resolve()
    created: list[Path] = []
    try:
        created = _make_parents(path.parent)
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        _remove_empty(created)
        raise InputError(f"{option} {_display(target)}: cannot write there ({exc.strerror})") from None
    os.close(fd)
    tmp = Path(name)
    _apply_umask(tmp, 0o666)
    try:
        yield tmp
        if not recognise(tmp):
            raise RuntimeError(f"bimrobot bug: the file written for {path} does not carry the bimrobot signature")
        replaced = check_output(target, folder=False, inputs=inputs, option=option, recognise=recognise)
        if replaced is not None:
            _announce(target, replaced, False, inputs)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        _remove_empty(created)
        raise


#: The file that marks an unfinished, resumable output folder (JSON: kind, fingerprint, inputs).
PARTIAL_MARKER = ".bimrobot-partial.json"


def partial_folder(target: str | os.PathLike) -> Path:
    """Where the unfinished output of a resumable command for ``target`` lives: ``.NAME.partial`` beside it."""
    path = Path(target).resolve()
    return path.with_name(f".{path.name}.partial")


@contextlib.contextmanager
def resumable_output_dir(
    target: str | os.PathLike, *, kind: str, fingerprint: dict, inputs: Iterable = (), option: str = "-o"
) -> Iterator[tuple[Path, bool]]:
    """Like :func:`atomic_output_dir`, for long commands that can be resumed after a kill.

    Yields ``(folder, resumed)``. The work goes into :func:`partial_folder`, which survives a SIGKILL or
    Ctrl-C; the same command run again (same ``fingerprint``: inputs and options) resumes it
    (``resumed`` True), a different one starts afresh and says so. On success the folder becomes
    ``target`` as in :func:`atomic_output_dir`; on any other failure it is removed with the parents this
    call created, so a failed run leaves nothing behind.
    """
    inputs = _resolved_inputs(inputs)
    check_output(target, folder=True, inputs=inputs, option=option)
    path = Path(target).resolve()
    staging = partial_folder(target)
    shown = _display(staging)
    resumed = False
    if staging.exists() or staging.is_symlink():
        if staging.is_symlink() or not staging.is_dir() or not (staging / PARTIAL_MARKER).is_file():
            raise InputError(f"{option} {_display(target)}: {shown} exists and bimrobot did not write it; move it away (nothing was changed)")
        try:
            earlier = json.loads((staging / PARTIAL_MARKER).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            earlier = {}
        if earlier.get("fingerprint") == fingerprint:
            resumed = True
            print(f"bimrobot: resuming the unfinished {kind} in {shown}", file=sys.stderr)
        else:
            print(f"bimrobot: discarding the unfinished {kind} in {shown} (it had other inputs or options)", file=sys.stderr)
            shutil.rmtree(staging)
    created: list[Path] = []
    try:
        created = _make_parents(path.parent)
        if not resumed:
            staging.mkdir()
            _apply_umask(staging, 0o777)
            (staging / PARTIAL_MARKER).write_text(json.dumps(
                {"kind": kind, "fingerprint": fingerprint, "inputs": [str(p) for p in inputs]}, indent=2), encoding="utf-8")
    except OSError as exc:
        _remove_empty(created)
        raise InputError(f"{option} {_display(target)}: cannot write there ({exc.strerror})") from None
    try:
        yield staging, resumed
        _finish_folder(staging, target, kind=kind, inputs=inputs, option=option)
        (path / PARTIAL_MARKER).unlink()
    except KeyboardInterrupt:
        print(f"bimrobot: interrupted; the same command resumes from {shown}", file=sys.stderr)
        raise
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        _remove_empty(created)
        raise
