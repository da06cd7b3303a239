"""Collision geometry of one element body for MuJoCo: a list of convex pieces (local frame, metres).

MuJoCo collides every mesh geom as its convex hull, so a concave member (an I or C section, an angle)
needs several pieces or its hull closes the gaps between flanges. The rule:

- a body whose volume is at least :data:`CONVEX_RATIO` of its convex hull's is *convex*: one piece,
  its hull;
- a concave body smaller than :data:`SMALL_PART_M` (bolts, nuts, cleats) keeps its hull: at that size
  the gaps the hull closes are millimetres, and CoACD spends up to 30 s on a cleat with bolt holes;
- any other closed body is *concave*: decomposed by CoACD (approximate convex decomposition, Wei et
  al. 2022, ``coacd`` on PyPI) into at most ``budget`` pieces (default :data:`DEFAULT_BUDGET`) within
  :data:`TIME_BUDGET_S` seconds of CPU time (a forked process on one OpenMP thread; over budget, the
  hull): CPU time, not wall time, so that the pieces do not depend on how loaded the machine is;
- a body CoACD cannot take (open, flat, degenerate) falls back to its hull, and says so.

:func:`collision_pieces` returns the pieces and the method in words, for the scene's report.
"""

from __future__ import annotations

import ctypes
import resource
from dataclasses import dataclass

import numpy as np
import trimesh

from bimrobot.export.inertia import Body, closed_and_consistent, convex_hull

CONVEX_RATIO = 0.9
"""Volume / hull volume at or above which a body counts as convex (a 10 % fill error at most)."""

SMALL_PART_M = 0.3
"""Largest extent (m) below which a concave body keeps its convex hull."""

TIME_BUDGET_S = 5
"""CPU seconds CoACD may take on one element (whole seconds: the kernel's RLIMIT_CPU; measured: 0.3-0.5 s
for the W sections of the steel frame). CPU time does not stretch with the load of other processes, as
wall time does (on a loaded 2-core machine a 0.3 s decomposition took 5.3 s of wall time)."""

HANG_GUARD_S = 600.0
"""Wall seconds after which a CoACD process that neither answers nor uses up its CPU budget is given up
(a hang guard only: a decomposition within its CPU budget finishes long before, however loaded)."""

DEFAULT_BUDGET = 8
"""Convex pieces per element at most: an I section takes 3 (two flanges, a web), an angle 2."""

# CoACD's settings: concavity threshold 0.02 (of the body's size) and a reduced tree search, which
# decomposes the chapter-4 W sections into 3 pieces in about 0.5 s each (the default search takes 2-7 s
# for the same pieces); the input is already a clean closed mesh, so no remeshing ("preprocess").
COACD_SETTINGS = dict(threshold=0.02, preprocess_mode="off", mcts_iterations=50, mcts_nodes=10, seed=0)


@dataclass(frozen=True)
class Collision:
    """Convex pieces [(vertices, faces), ...] and how they were made ("convex hull", "CoACD")."""

    pieces: list[tuple[np.ndarray, np.ndarray]]
    method: str
    fill_ratio: float  # volume of the pieces' hulls / volume of the body (1.0: exact)


def collision_pieces(body: Body, budget: int = DEFAULT_BUDGET) -> Collision:
    """The convex pieces of ``body`` (see the module docstring); ``budget`` >= 1 pieces at most."""
    hull = body.hull
    if hull is None:  # flat: MuJoCo thickens a flat mesh by its margin; keep the body as it is
        return Collision([(body.vertices, body.faces)], "body (flat, no hull)", 1.0)
    hull_volume = trimesh.Trimesh(*hull, process=False).volume
    closed = closed_and_consistent(body.faces)
    volume = abs(trimesh.Trimesh(body.vertices, body.faces, process=False).volume) if closed else 0.0
    if not closed or volume <= 0:
        return Collision([hull], "convex hull (open body)", 1.0)
    if volume >= CONVEX_RATIO * hull_volume or budget == 1:
        return Collision([hull], "convex hull", hull_volume / volume)
    size = float(np.ptp(body.vertices, axis=0).max())
    if size < SMALL_PART_M:
        return Collision([hull], f"convex hull (small part, {size:.2f} m)", hull_volume / volume)
    parts = _coacd(body, budget)
    if isinstance(parts, str):
        return Collision([hull], f"convex hull ({parts})", hull_volume / volume)
    pieces = [piece for piece in (convex_hull(np.asarray(v, float)) for v in parts) if piece is not None]
    if not pieces:
        return Collision([hull], "convex hull (CoACD found no piece)", hull_volume / volume)
    filled = sum(trimesh.Trimesh(*piece, process=False).volume for piece in pieces)
    return Collision(pieces, f"CoACD ({len(pieces)} pieces)", filled / volume)


def require_coacd() -> None:
    """Say now, before the geometry work, when CoACD (the physics extra) is not installed, without
    importing it: it is loaded only in the forked process that decomposes (:func:`_decompose`). Loaded
    in the command's own process, a later ``import rclpy`` there crashes with SIGSEGV."""
    import importlib.util

    from bimrobot.core.errors import MissingExtraError

    if importlib.util.find_spec("coacd") is None:
        raise MissingExtraError("this command needs the optional dependency 'coacd': pip install 'bimrobot[physics]'")


class _NoAnswer(Exception):
    """The CoACD process sent nothing: over its CPU budget (the kernel's SIGXCPU), crashed, or hung."""


def _coacd(body: Body, budget: int) -> list[np.ndarray] | str:
    """CoACD's pieces (vertex arrays) of ``body``, or why there are none, in words: CoACD's own error,
    or over its :data:`TIME_BUDGET_S` of CPU (said too of a process that gives no answer within
    :data:`HANG_GUARD_S`, a hang guard only)."""
    from bimrobot.core.forked import Forked

    worker = Forked(_decompose, (body.vertices, body.faces, budget))
    try:
        return worker.outcome(died=_NoAnswer, timeout_s=HANG_GUARD_S)
    except _NoAnswer:
        return f"CoACD over its {TIME_BUDGET_S:g} s CPU budget"
    except Exception as exc:  # noqa: BLE001 - CoACD rejected this mesh: the hull stands in, and says why
        return f"CoACD failed: {exc}"
    finally:
        worker.stop()


def _decompose(vertices: np.ndarray, faces: np.ndarray, budget: int) -> list[np.ndarray]:
    """In the forked process (:class:`bimrobot.core.forked.Forked`): CoACD's pieces' vertices, under
    an RLIMIT_CPU of :data:`TIME_BUDGET_S` seconds and on one OpenMP thread."""
    import coacd  # imported here: only concave members need it

    hard = resource.getrlimit(resource.RLIMIT_CPU)[1]
    resource.setrlimit(resource.RLIMIT_CPU, (TIME_BUDGET_S if hard == resource.RLIM_INFINITY else min(TIME_BUDGET_S, hard), hard))
    _one_openmp_thread()

    coacd.set_log_level("error")
    parts = coacd.run_coacd(coacd.Mesh(vertices, faces), max_convex_hull=budget, **COACD_SETTINGS)
    return [np.asarray(v, float) for v, _ in parts]


def _one_openmp_thread() -> None:
    """CoACD cuts the parts of each round on OpenMP threads and keeps them in the order the threads
    finish them; on one thread its pieces depend on the mesh and the seed alone. (OMP_NUM_THREADS is
    read when OpenMP loads, which may be in the parent, before this fork: set it through the library.)"""
    with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
        libraries = {line.split(maxsplit=5)[-1].strip() for line in maps if "libgomp" in line}
    for library in sorted(libraries):
        ctypes.CDLL(library).omp_set_num_threads(1)
