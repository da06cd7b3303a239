"""How much creating a file costs in a folder right after many files were deleted there.

ext4 without a journal skips, when it creates a file or folder, every free inode of the group that was
deleted in the last 60 s but not in the current second (6 minutes while its inode table block is not
yet written back: the kernel's ``recently_deleted()`` in fs/ext4/ialloc.c). Each skipped inode costs a look-up, so after a big
deletion each new entry can cost ten times its price; with a journal the check is off. A package of
``bimrobot convert`` has about 1,700 entries for 300 elements, so this decides up to 1 CPU s of a
conversion written where an earlier one was just deleted (docs/evidence/world.md, "Speed").

    .venv/bin/python bench/inode_reuse.py [FOLDER]     # default: TMPDIR

Prints the kernel CPU milliseconds per file created: in a fresh folder, then right after
deleting ``--deleted`` files beside it (2 s after: inodes deleted in the same second are reused at once).
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from convert import file_system  # noqa: E402  (bench/ is not a package)


def _kernel_s() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_stime


def create_ms(folder: Path, count: int) -> float:
    """Kernel CPU milliseconds per empty file of ``count`` created in the new folder ``folder``."""
    folder.mkdir()
    start = _kernel_s()
    for index in range(count):
        os.close(os.open(folder / str(index), os.O_CREAT | os.O_WRONLY, 0o644))
    return 1000 * (_kernel_s() - start) / count


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder", nargs="?", type=Path, default=Path(tempfile.gettempdir()))
    parser.add_argument("--files", type=int, default=1116, help="files created each time (GEELEN's package: 1,116)")
    parser.add_argument("--deleted", type=int, default=6000, help="files deleted before the second creation")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(dir=args.folder, prefix="bimrobot-inodes-") as tmp:
        root = Path(tmp)
        fresh = create_ms(root / "fresh", args.files)
        churn = root / "deleted"
        create_ms(churn, args.deleted)
        for index in range(args.deleted):
            (churn / str(index)).unlink()
        time.sleep(2.0)
        after = create_ms(root / "after", args.files)
    print(f"{args.folder} ({file_system(args.folder)}): {fresh:.3f} ms per file created in a fresh folder, "
          f"{after:.3f} ms 2 s after {args.deleted:,} files were deleted beside it")
    return 0


if __name__ == "__main__":
    sys.exit(main())
