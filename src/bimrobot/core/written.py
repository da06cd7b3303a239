"""Files written with their SHA-256 taken from the bytes in hand, so that an output folder's marker
(:func:`bimrobot.core.io.manifest`) need not read them back.

A package holds four files per model (1,213 files for MULTICOM-Prefab); hashing them again at the end
cost 0.16 s of CPU there, mostly path handling and reads. :func:`write_bytes` and :func:`write_text`
write a file and note its size, modification time, inode and SHA-256; the manifest takes a noted
digest when the file it lists still has that size, time and inode, and hashes any other file itself.
A file changed after it was noted, to the same size within the same clock tick of the file system, would
be listed with its old digest: bimrobot writes each file of an output once. Notes made in a worker
process reach the parent through :mod:`bimrobot.core.pool` (:func:`take_notes`, :func:`add_notes`).
"""

from __future__ import annotations

import hashlib
import os

_notes: dict[str, tuple[int, int, int, str]] = {}
"""Absolute path -> (size in bytes, modification time in ns, inode, SHA-256 hex) of files written here."""


def write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` (created or truncated) and note its digest."""
    with open(path, "wb") as stream:
        stream.write(data)
        stream.flush()
        info = os.fstat(stream.fileno())
    _notes[os.path.abspath(path)] = (info.st_size, info.st_mtime_ns, info.st_ino, hashlib.sha256(data).hexdigest())


def write_text(path: str | os.PathLike, text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` as :meth:`pathlib.Path.write_text` would (line ends as the platform writes them)
    and note its digest."""
    if os.linesep != "\n":
        text = text.replace("\n", os.linesep)
    write_bytes(path, text.encode(encoding))


def noted_digest(path: str, info: os.stat_result) -> str | None:
    """The SHA-256 noted for the file at ``path`` (absolute) whose ``os.lstat`` is ``info``, or None when
    it was not written here or has changed since."""
    note = _notes.get(path)
    if note is None or note[:3] != (info.st_size, info.st_mtime_ns, info.st_ino):
        return None
    return note[3]


def take_notes() -> dict[str, tuple[int, int, int, str]]:
    """The notes made in this process since the last call (a pool worker's, for its parent); forgets them."""
    global _notes
    notes, _notes = _notes, {}
    return notes


def add_notes(notes: dict[str, tuple[int, int, int, str]]) -> None:
    """Take in notes made in another process (a pool worker's, from :func:`take_notes`)."""
    _notes.update(notes)


def forget_under(folder: str | os.PathLike) -> None:
    """Drop the notes of files under ``folder`` (its output is finished, or abandoned)."""
    prefix = os.path.join(os.path.abspath(folder), "")
    for path in [p for p in _notes if p.startswith(prefix)]:
        del _notes[path]
