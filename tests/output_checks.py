"""What the output-policy tests compare: the state of a folder tree before and after a command."""

from __future__ import annotations

import os
from pathlib import Path


def snapshot(root: Path) -> dict[str, bytes]:
    """Every path under ``root`` -> its bytes (files), its target (symbolic links) or ``b"<dir>"``.

    Equal snapshots mean every file is byte for byte the same and nothing was added, not even an
    empty folder.
    """
    state = {}
    for path in sorted(root.rglob("*")):
        key = str(path.relative_to(root))
        if path.is_symlink():
            state[key] = b"-> " + os.readlink(path).encode()
        elif path.is_dir():
            state[key] = b"<dir>"
        else:
            state[key] = path.read_bytes()
    return state
