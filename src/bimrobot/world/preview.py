"""The package's preview picture drawn by a helper process that gets ready while the package is made.

Drawing ``preview.png`` (:func:`bimrobot.world.render.render_preview`) needs matplotlib, whose import
alone takes 0.3-0.9 s here: more than IfcOpenShell's whole geometry pass on a 100-element model. So
:class:`PreviewWorker` forks a process when the conversion starts; it imports the drawing libraries
while the parent reads the IFC file and writes the models (the reader's Python leaves a core mostly
idle), then draws the picture of the finished folder when asked. Where ``fork`` is not available
(or the helper dies) the picture is drawn in this process, with the same result.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
from pathlib import Path

from bimrobot.world import pool

log = logging.getLogger(__name__)


def _prepare() -> None:
    """Import what drawing the preview needs (the slow part when done at the end)."""
    import matplotlib

    matplotlib.use("Agg")
    import collada  # noqa: F401
    import matplotlib.pyplot  # noqa: F401
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: F401

    from bimrobot.world import render  # noqa: F401


def _draw(package: str, triangles: int) -> str | None:
    from bimrobot.world.render import render_preview

    return render_preview(Path(package), triangles)


def _serve(connection) -> None:
    """The helper process: get ready, then draw one picture when asked."""
    try:
        _prepare()
    except Exception:  # drawn without the preparation then; the error shows there
        pass
    try:
        request = connection.recv()
    except EOFError:
        return
    try:
        connection.send(("ok", _draw(*request)))
    except BaseException as exc:  # sent back and raised in the parent, as if drawn there
        connection.send(("error", exc))


class PreviewWorker:
    """Draws a package's preview in a process forked at construction (see the module docstring).

    Use as a context manager: :meth:`start` asks for the picture, :meth:`result` returns what
    ``render_preview`` returns (the picture's name, or None when the world is too large to draw) and
    raises what it raises."""

    def __init__(self, enabled: bool = True) -> None:
        self._process = self._connection = None
        self._request: tuple[str, int] | None = None
        # (a daemonic process, such as a pool worker, may not start processes of its own)
        if enabled and pool.can_fork() and pool.cores() > 1 and not multiprocessing.current_process().daemon:
            parent, child = multiprocessing.get_context("fork").Pipe()
            self._process = multiprocessing.get_context("fork").Process(target=_serve, args=(child,), daemon=True)
            self._process.start()
            child.close()
            self._connection = parent

    def start(self, package: Path, triangles: int) -> None:
        """Begin drawing ``package/preview.png`` (a folder whose worlds and models are written), of a
        world of ``triangles`` visual triangles; :meth:`result` waits for it."""
        self._request = (str(package), triangles)
        if self._connection is not None:
            try:
                self._connection.send(self._request)
            except (OSError, ValueError):  # the helper died: drawn here by result()
                self.close()

    def result(self) -> str | None:
        """What ``render_preview`` returned for the picture :meth:`start` began (raises what it raised)."""
        if self._connection is not None:
            try:
                status, value = self._connection.recv()
            except (EOFError, OSError):  # the helper died: draw here
                log.debug("preview helper process ended early; drawing in this process")
            else:
                self.close()
                if status == "error":
                    raise value
                return value
            self.close()
        return _draw(*self._request)

    @contextlib.contextmanager
    def stopped_on_error(self):
        """Stop the helper at once when the block fails (before the package folder is removed, so that
        no picture is drawn into a folder being removed)."""
        try:
            yield self
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        """Stop the helper process at once (it has sent its picture's result, or none is wanted)."""
        if self._process is None:
            return
        self._connection.close()
        self._process.terminate()
        self._process.join()
        self._process = self._connection = None

    def __enter__(self) -> "PreviewWorker":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
