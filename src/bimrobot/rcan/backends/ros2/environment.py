"""The ROS 2 environment of the ``ros2`` backend: finding and loading rclpy and RCAN's action package,
the names both sides of the action use, and cleaning up Fast DDS's shared memory.

Finding ROS 2: the pinned ``ros-jazzy-*`` wheels in the venv plus the action package that
``scripts/setup-ros2.sh`` builds into ``<venv>/ros2_ws/install`` (or ``$BIMROBOT_ROS2_INSTALL``); with a
sourced ROS 2 install and the package built in your workspace, that is used as is.
"""

from __future__ import annotations

import contextlib
import ctypes
import glob
import os
import sys
from pathlib import Path

from bimrobot.core.errors import MissingExtraError
from bimrobot.rcan.activities import ActivityKind

SETUP_HINT = "run scripts/setup-ros2.sh .venv (ROS 2 Jazzy wheels + the bimrobot_interfaces action package)"
_LIBRARY_ORDER = ("generator_c", "typesupport_c", "typesupport_introspection_c", "typesupport_fastrtps_c",
                  "typesupport_cpp", "typesupport_introspection_cpp", "typesupport_fastrtps_cpp", "generator_py")
_loaded = False
#: The feedback phase of the robot node's heartbeat (sent every 0.5 s while a goal runs).
HEARTBEAT = "alive"
HEARTBEAT_S = 0.5


def interfaces_install() -> Path:
    """Where the built bimrobot_interfaces package lives (``$BIMROBOT_ROS2_INSTALL`` or the venv's)."""
    return Path(os.environ.get("BIMROBOT_ROS2_INSTALL", Path(sys.prefix) / "ros2_ws" / "install"))


def load_ros2():
    """Import rclpy and the ConstructionActivity action; MissingExtraError with the fix when absent."""
    global _loaded
    install = interfaces_install()
    if not _loaded and (install / "lib").is_dir():
        site = next(iter(glob.glob(str(install / "lib" / "python3*" / "site-packages"))), None)
        if site and site not in sys.path:
            sys.path.insert(0, site)
        os.environ["AMENT_PREFIX_PATH"] = os.pathsep.join(
            [str(install), os.environ.get("AMENT_PREFIX_PATH", sys.prefix)])
        os.environ["LD_LIBRARY_PATH"] = os.pathsep.join([str(install / "lib"), os.environ.get("LD_LIBRARY_PATH", "")])
        # The loader read LD_LIBRARY_PATH at process start: load the package's libraries explicitly.
        for suffix in _LIBRARY_ORDER:
            library = install / "lib" / f"libbimrobot_interfaces__rosidl_{suffix}.so"
            if library.exists():
                ctypes.CDLL(str(library), mode=ctypes.RTLD_GLOBAL)
        _loaded = True
    try:
        import rclpy
        from bimrobot_interfaces.action import ConstructionActivity
    except ImportError as exc:
        raise MissingExtraError(f"the ros2 backend needs ROS 2 and RCAN's action package ({exc}): {SETUP_HINT}") from None
    return rclpy, ConstructionActivity


def ros2_available() -> tuple[bool, str]:
    """(True, "") when the ros2 backend can run here, else (False, why)."""
    try:
        load_ros2()
    except MissingExtraError as exc:
        return False, str(exc)
    return True, ""

def action_name(robot: str, kind: ActivityKind | str) -> str:
    return f"/bimrobot/{robot}/{ActivityKind(kind).value}"


#: Shared-memory files of Fast DDS in /dev/shm: Fast DDS 2.x (Jazzy's wheels) names its segments,
#: ports and their semaphores ``fastrtps_*`` / ``sem.fastrtps_*``; Fast DDS 3 uses ``fastdds_*``.
SHM_PATTERNS = ("fastrtps_*", "sem.fastrtps_*", "fastdds_*", "sem.fastdds_*")


def fastdds_files() -> set[str]:
    """The Fast DDS shared-memory files in /dev/shm now (take it before starting ROS 2 processes)."""
    return {path for pattern in SHM_PATTERNS for path in glob.glob(f"/dev/shm/{pattern}")}


def _shm_in_use(ignore_pid: int | None = None) -> set[str]:
    """/dev/shm files a live process (other than ``ignore_pid``) has mapped or open."""
    used = set()
    for proc in glob.glob("/proc/[0-9]*"):
        if ignore_pid is not None and proc == f"/proc/{ignore_pid}":
            continue
        with contextlib.suppress(OSError):
            with open(f"{proc}/maps", encoding="utf-8", errors="replace") as maps:
                used.update(line.split(None, 5)[5].strip() for line in maps if "/dev/shm/" in line)
        with contextlib.suppress(OSError):
            for fd in os.listdir(f"{proc}/fd"):
                with contextlib.suppress(OSError):
                    target = os.readlink(f"{proc}/fd/{fd}")
                    if target.startswith("/dev/shm/"):
                        used.add(target)
    return {path.removesuffix(" (deleted)") for path in used}


def stale_fastdds_files(before: set[str], ignore_pid: int | None = None) -> set[str]:
    """The Fast DDS shared-memory files created since ``before`` that no live process uses: a file another
    ROS 2 program maps is in use, and so is the semaphore (``sem.<name>_mutex``) of a port it maps.
    ``ignore_pid``: a process whose participants are all closed and whose mappings go with it."""
    candidates = fastdds_files() - before
    if not candidates:
        return set()
    used = {path[len("/dev/shm/"):] for path in _shm_in_use(ignore_pid)}
    return {path for path in candidates
            if path[len("/dev/shm/"):] not in used
            and not (path.startswith("/dev/shm/sem.") and path[len("/dev/shm/sem."):].removesuffix("_mutex") in used)}


def cleanup_fastdds(before: set[str], ignore_pid: int | None = None) -> list[str]:
    """Delete the Fast DDS shared-memory files created since ``before`` that no live process uses (a
    killed process leaves them, and Fast DDS leaves its port segments); see ``stale_fastdds_files``."""
    removed = []
    for path in sorted(stale_fastdds_files(before, ignore_pid)):
        with contextlib.suppress(OSError):
            os.unlink(path)
            removed.append(path)
    return removed
