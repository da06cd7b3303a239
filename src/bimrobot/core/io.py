"""The one output policy: every file or folder bimrobot writes goes through this module.

Rule (checked before the work starts and again when the result is put in place):

* refused, with one sentence (an :class:`~bimrobot.core.errors.InputError`, exit 2): the current directory
  or a folder that contains it, an input file, a folder that contains an input, an existing file or a
  non-empty folder that bimrobot did not write, a file where a folder is wanted (and the reverse), a
  path under a regular file, and a path whose folder cannot be written; a symlink is judged by what it
  points at;
* replaced, saying so in one line on stderr: a folder bimrobot wrote, unchanged since (it holds
  :data:`MARKER`, whose manifest lists every file with its size and SHA-256, and the folder holds
  exactly those files, byte for byte), by a command of the same kind; or a file bimrobot wrote (it
  carries :data:`SIGNATURE`, or a kind-specific recogniser says so);
* refused as well: a folder bimrobot wrote to which anything was added, in which anything was changed
  or removed since (the message names up to :data:`SHOWN_FOREIGN` such files), one written by another
  kind of command (a ``simulate`` output is not replaced by a ``split``), and one whose marker lists no
  files (written before markers had a manifest, or a folder that grows run by run): bimrobot cannot
  tell what in it is the user's, so the user deletes it or gives another folder;
* written atomically: into a temporary sibling that is renamed into place at the end. On any failure
  the temporary sibling and any parent folder the run created are removed, so nothing is left behind.

Writers of single files put :data:`SIGNATURE` in the file's first 64 KiB (a comment, a JSON key, a PNG
text chunk, ...): that is how a later run knows the file is bimrobot's to replace.
"""

from __future__ import annotations

import contextlib
import datetime
import fnmatch
import hashlib
import json
import os
import shutil
import stat
import sys
import tempfile
import uuid
from pathlib import Path
from typing import Callable, Iterable, Iterator

from bimrobot import __version__
from bimrobot.core import written
from bimrobot.core.errors import InputError

#: The file that marks a folder as written by bimrobot (JSON: kind, inputs, version, time, and the
#: manifest ``files``: every file's path relative to the folder, with its size in bytes and SHA-256).
MARKER = ".bimrobot-output.json"

#: The file that marks an unfinished, resumable output folder (JSON: kind, fingerprint, inputs).
PARTIAL_MARKER = ".bimrobot-partial.json"

#: How many foreign (added, changed or removed) files a refusal names; the rest are counted.
SHOWN_FOREIGN = 3

#: Files that a later bimrobot command changes in an output of this kind, by kind: patterns
#: (:mod:`fnmatch`, top-level names) a marker records as ``managed`` and the check does not hold
#: against the folder. An Oxigraph store is a RocksDB database: opening it to query it (``bimrobot
#: query``) rewrites its log, manifest, options and table files; anything else added is still foreign.
MANAGED_FILES = {
    "graph (Oxigraph store)": ("[0-9]*.log", "[0-9]*.sst", "[0-9]*.blob", "CURRENT", "IDENTITY", "LOCK", "LOG",
                               "LOG.old.*", "MANIFEST-*", "OPTIONS-*"),
}

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


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes (hex), read in 1 MiB blocks."""
    sha = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            sha.update(block)
    return sha.hexdigest()


def manifest(folder: Path) -> dict[str, dict]:
    """Every entry under ``folder`` (symbolic links not followed), by its path relative to ``folder``
    ('/'-separated): ``{"size": bytes, "sha256": hex}`` for a file, ``{"dir": True}`` for a folder,
    ``{"link": target}`` for a symbolic link, in :func:`os.walk`'s order (a folder's subfolders, then
    its files, then each subfolder's entries). The markers themselves (:data:`MARKER`,
    :data:`PARTIAL_MARKER` at the top) are left out: they are bimrobot's bookkeeping, not content. A
    file written through :mod:`bimrobot.core.written` and unchanged since is not read again."""
    entries: dict[str, dict] = {}
    _list_folder(os.path.abspath(folder), "", entries)
    return entries


def _list_folder(folder: str, prefix: str, entries: dict[str, dict]) -> None:
    """Add the entries of ``folder`` (absolute) to ``entries``, their keys after ``prefix``, then those
    of each subfolder (not followed through a symbolic link), as :func:`manifest` describes."""
    folders, files = [], []
    try:
        with os.scandir(folder) as listing:
            for entry in listing:
                try:
                    (folders if entry.is_dir() else files).append(entry)
                except OSError:
                    files.append(entry)
    except OSError:
        return
    for entry in folders + files:
        key = prefix + entry.name
        if key in (MARKER, PARTIAL_MARKER):
            continue
        info = entry.stat(follow_symlinks=False)
        if stat.S_ISLNK(info.st_mode):
            entries[key] = {"link": os.readlink(entry.path)}
        elif stat.S_ISDIR(info.st_mode):
            entries[key] = {"dir": True}
        else:
            digest = written.noted_digest(entry.path, info) or file_digest(Path(entry.path))
            entries[key] = {"size": info.st_size, "sha256": digest}
    for entry in folders:
        if not entry.is_symlink():
            _list_folder(entry.path, prefix + entry.name + "/", entries)


def _differences(folder: Path, listed: dict, managed: Iterable[str] = ()) -> list[str]:
    """What in ``folder`` is not as its manifest ``listed`` says: ``'notes.txt' (added)``, ``(changed)``,
    ``(removed)``, sorted by path. A file whose size differs is not hashed; top-level names matching a
    ``managed`` pattern (:data:`MANAGED_FILES`) are not compared."""
    found: list[str] = []
    seen = set()
    managed = tuple(p for p in managed if isinstance(p, str))
    listed = {k: v for k, v in listed.items() if not ("/" not in k and any(fnmatch.fnmatchcase(k, p) for p in managed))}
    for root, dirs, files in os.walk(folder):
        base = Path(root)
        for name in dirs + files:
            path = base / name
            key = path.relative_to(folder).as_posix()
            if key in (MARKER, PARTIAL_MARKER) or (base == folder and any(fnmatch.fnmatchcase(key, p) for p in managed)):
                continue
            seen.add(key)
            want = listed.get(key)
            if not isinstance(want, dict):
                found.append(f"{key!r} (added)")
            elif not _matches(path, want):
                found.append(f"{key!r} (changed)")
    found.extend(f"{key!r} (removed)" for key in listed if key not in seen)
    return sorted(found)


def _matches(path: Path, want: dict) -> bool:
    """Whether ``path`` is the entry ``want`` of a manifest (same kind, size, SHA-256 or link target)."""
    if path.is_symlink():
        return "link" in want and os.readlink(path) == want["link"]
    if path.is_dir():
        return want.get("dir") is True
    try:
        return path.stat().st_size == want.get("size") and file_digest(path) == want.get("sha256")
    except OSError:
        return False


def _read_marker(folder: Path) -> dict:
    try:
        marker = json.loads((folder / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return marker if isinstance(marker, dict) else {}


def _check_marked_folder(path: Path, shown: str, option: str, kind: str | None) -> None:
    """Refuse the marked folder ``path`` unless it is, file for file, what bimrobot wrote there, and (when
    ``kind`` is given) written by a command of that kind."""
    marker = _read_marker(path)
    what = describe_folder(path)
    how = "give another folder, or delete it yourself if you mean to replace it (nothing was changed)"
    if kind is not None and marker.get("kind") != kind:
        raise InputError(f"{option} {shown} holds a {what}, not a {kind} output; {how}")
    listed = marker.get("files")
    if not isinstance(listed, dict):
        raise InputError(f"{option} {shown} holds a {what} that does not list its files (an older or growing folder), "
                         f"so bimrobot cannot tell whether anything in it is yours; {how}")
    managed = marker.get("managed")
    differences = _differences(path, listed, managed if isinstance(managed, list) else ())
    if differences:
        named = ", ".join(printable(d) for d in differences[:SHOWN_FOREIGN])
        more = f" and {len(differences) - SHOWN_FOREIGN} more" if len(differences) > SHOWN_FOREIGN else ""
        raise InputError(f"{option} {shown} holds a {what}, but it was changed since: {named}{more}; {how}")


def check_output(
    target: str | os.PathLike,
    *,
    folder: bool,
    inputs: Iterable = (),
    option: str = "-o",
    recognise: Recogniser = has_signature,
    kind: str | None = None,
) -> Path | None:
    """Apply the output policy to ``target``; return the resolved path of what would be replaced, or None.

    ``folder``: the output is a folder (else a file). ``inputs``: the files the command reads (paths;
    None, ``:memory:``, URLs and ``generated:`` specs are ignored). ``option``: how the user named the
    path, for the message. ``recognise``: for file outputs, tells whether an existing file is bimrobot's.
    ``kind``: for folder outputs, the command kind that will write it (as in its marker); a folder
    another kind wrote is refused. None accepts any kind (the content is checked all the same).
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
            _check_marked_folder(path, shown, option, kind)
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


def _marker(kind: str, inputs: list[Path], folder: Path) -> str:
    """The marker of the finished ``folder``: what wrote it, from what, when, and its manifest."""
    return json.dumps(
        {
            "kind": kind,
            "inputs": [str(p) for p in inputs],
            "bimrobot": __version__,
            "written": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
            "files": manifest(folder),
            "managed": list(MANAGED_FILES.get(kind, ())),
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
    check_output(target, folder=True, inputs=inputs, option=option, kind=kind)
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
    finally:
        written.forget_under(tmp)  # the digests noted of its files (bimrobot.core.written) are spent


def _finish_folder(tmp: Path, target: str | os.PathLike, *, kind: str, inputs: list[Path], option: str) -> None:
    """Mark the finished folder ``tmp`` as bimrobot's, check ``target`` again (it may have changed during
    the work) and put ``tmp`` in its place, announcing what it replaces."""
    (tmp / MARKER).write_text(_marker(kind, inputs, tmp), encoding="utf-8")
    replaced = check_output(target, folder=True, inputs=inputs, option=option, kind=kind)
    if replaced is not None:
        _announce(target, replaced, True, inputs)
    _put_folder_in_place(tmp, Path(target).resolve(), option)


def _put_folder_in_place(tmp: Path, path: Path, option: str = "-o") -> None:
    """Rename ``tmp`` onto ``path``; an existing ``path`` (checked to be ours or empty) goes away after.

    The old folder is moved aside first and checked once more against its manifest there (nothing can
    be added to it any more under its hidden name): a file written into it since the last check puts it
    back and refuses, instead of being deleted with it."""
    if not path.exists():
        tmp.rename(path)
        return
    backup = path.with_name(f".{path.name}.{uuid.uuid4().hex[:8]}.old")
    path.rename(backup)
    try:
        if (backup / MARKER).is_file():
            _check_marked_folder(backup, _display(path), option, None)
        elif any(backup.iterdir()):
            raise InputError(f"{option} {_display(path)} is a folder that bimrobot did not write and it is not empty; "
                             "give a new or empty folder (nothing was changed)")
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
    check_output(target, folder=True, inputs=inputs, option=option, kind=kind)
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
    finally:
        written.forget_under(staging)
