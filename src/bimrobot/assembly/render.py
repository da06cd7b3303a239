"""Pictures of an assembly episode: a 3D view in the thesis' colours (matplotlib, Agg) and a text map.

Colours (thesis fig. 6.2): waiting components orange, the moving one blue, the one that has just arrived
green, assembled (placed earlier, or prebuilt) pink; free targets pink wireframes and the moving
component's start pose an orange wireframe. The yard is grey, the construction area cyan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bimrobot.assembly.scenario import Scenario
from bimrobot.core.io import signature

Cell = tuple[int, int, int]

COLOURS = {
    "waiting": "#f39c34",
    "current": "#2f6fdb",
    "arrived": "#3cb44b",
    "placed": "#f28cc0",
    "prebuilt": "#f28cc0",
    "obstacle": "#7f7f7f",
    "foundation": "#404040",
    "yard": "#d0d0d0",
    "construction": "#9fe3ea",
    "target": "#e0408a",
    "start": "#f39c34",
}


@dataclass(frozen=True)
class EpisodeView:
    """What a picture of an assembly episode shows; cells are grid indices (x, y, z), z up.

    ``components``: id -> (state, cells), state one of 'waiting', 'current', 'placed', 'prebuilt'.
    ``start_cells``: the moving component's start pose (None when nothing moves). ``elapsed``: steps of
    the episode; ``steps``: steps on the moving component; ``standing`` of ``total`` components stand.
    """

    scenario: Scenario
    components: dict[str, tuple[str, list[Cell]]]
    filled_targets: list[bool]
    current: str | None
    arrived: str | None
    start_cells: list[Cell] | None
    elapsed: int
    steps: int
    standing: int
    total: int


def _box_faces(lo, hi) -> list[list[tuple[float, float, float]]]:
    """The six faces of the axis-aligned box [lo, hi] (metres of cells)."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    corners = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0), (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    idx = [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (2, 3, 7, 6), (1, 2, 6, 5), (0, 3, 7, 4)]
    return [[corners[i] for i in face] for face in idx]


def _box_edges(lo, hi) -> list[list[tuple[float, float, float]]]:
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    c = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0), (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    pairs = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
    return [[c[a], c[b]] for a, b in pairs]


def _cells_box(cells) -> tuple[tuple[int, int, int], tuple[int, int, int]]:
    arr = np.asarray(cells)
    return tuple(arr.min(axis=0)), tuple(arr.max(axis=0) + 1)


class Renderer:
    """Draws frames of one scenario into a reused matplotlib figure (Agg backend, no display needed)."""

    def __init__(self, scenario: Scenario, size: tuple[int, int] = (640, 480)):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.scenario = scenario
        dpi = 80
        self.fig = Figure(figsize=(size[0] / dpi, size[1] / dpi), dpi=dpi)
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_subplot(projection="3d")
        self.fig.subplots_adjust(left=-0.08, right=1.05, bottom=0.02, top=1.04)
        self._window = None
        self._draw_site()
        self._draw_legend()
        self.title = self.fig.text(0.5, 0.95, "", ha="center", fontsize=10)
        self._obstacle_faces = [
            face
            for box in scenario.obstacles
            for face in _box_faces((box.x[0], box.y[0], box.z[0]), (box.x[1] + 1, box.y[1] + 1, box.z[1] + 1))
        ]
        # the view never changes: draw the axes and the ground once and blit the moving parts on top
        self.canvas.draw()
        self._background = self.canvas.copy_from_bbox(self.fig.bbox)

    def _draw_site(self) -> None:
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        sc, ax = self.scenario, self.ax
        W, L, H = sc.grid
        ax.set_xlim(0, W)
        ax.set_ylim(0, L)
        ax.set_zlim(0, H)
        ax.set_box_aspect((W, L, H))
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        ax.set_zlabel("z")
        ax.view_init(elev=32, azim=-58)
        faces, colours = [], []
        for box in sc.yard:
            # node1 regions; a lying component reaches up to 3 cells back from its node1
            lo = (max(box.x[0] - 3, 0), max(box.y[0] - 3, 0), 0.0)
            faces.append(_box_faces(lo, (box.x[1] + 1, box.y[1] + 1, 0.02))[1])
            colours.append(COLOURS["yard"])
        area = sc.construction_area
        if area is not None:
            faces.append(_box_faces((area.x[0], area.y[0], 0.0), (area.x[1] + 1, area.y[1] + 1, 0.03))[1])
            colours.append(COLOURS["construction"])
        for x, y in sc.foundations:
            faces += _box_faces((x, y, 0.0), (x + 1, y + 1, 1.0))
            colours += [COLOURS["foundation"]] * 6
        if faces:
            ax.add_collection3d(Poly3DCollection(faces, facecolors=colours, edgecolors="#555555", linewidths=0.3))

    def _draw_legend(self) -> None:
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch

        handles = [
            Patch(color=COLOURS["waiting"], label="waiting"),
            Patch(color=COLOURS["current"], label="moving"),
            Patch(color=COLOURS["arrived"], label="arrived"),
            Patch(color=COLOURS["placed"], label="assembled"),
            Line2D([], [], color=COLOURS["target"], label="free target"),
        ]
        if self.scenario.obstacles:
            handles.append(Patch(color=COLOURS["obstacle"], alpha=0.5, label="obstacle"))
        self.fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8, frameon=False)

    def draw(self, view: EpisodeView) -> np.ndarray:
        """An RGB frame (H, W, 3) uint8 of one moment of the episode."""
        from matplotlib.colors import to_rgba
        from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

        sc = view.scenario
        faces = list(self._obstacle_faces)
        colours = [to_rgba(COLOURS["obstacle"], 0.35)] * len(faces)
        arrived = view.arrived
        current = view.current
        for cid, (state, cells) in view.components.items():
            colour = COLOURS["arrived"] if cid == arrived else COLOURS[state]
            lo, hi = _cells_box(cells)
            faces += _box_faces(lo, hi)
            colours += [to_rgba(colour)] * 6
        edges, edge_colours = [], []
        for target, filled in zip(sc.targets, view.filled_targets):
            if not filled:
                lo, hi = _cells_box(target.cells)
                edges += _box_edges(lo, hi)
                edge_colours += [COLOURS["target"]] * 12
        if view.start_cells is not None:
            lo, hi = _cells_box(view.start_cells)
            edges += _box_edges(lo, hi)
            edge_colours += [COLOURS["start"]] * 12
        artists = []
        if edges:
            lines = Line3DCollection(edges, colors=edge_colours, linewidths=1.2)
            lines.axes = self.ax
            lines.set_transform(self.ax.transData)
            artists.append(lines)
        if faces:
            solids = Poly3DCollection(faces, facecolors=colours, edgecolors="#222222", linewidths=0.4)
            solids.axes = self.ax
            solids.set_transform(self.ax.transData)
            artists.append(solids)
        title = f"{sc.name}   step {view.elapsed}   standing {view.standing}/{view.total}"
        if current is not None:
            title += f"   moving {current}"
        self.title.set_text(title)
        self.canvas.restore_region(self._background)
        renderer = self.canvas.get_renderer()
        for artist in artists:
            artist.set_figure(self.fig)
            artist.do_3d_projection()
            artist.draw(renderer)
        self.title.draw(renderer)
        return np.asarray(self.canvas.buffer_rgba())[..., :3].copy()

    def show(self, frame: np.ndarray) -> None:
        """Show a frame in a window (human mode); without a display, does nothing."""
        import os

        if not os.environ.get("DISPLAY") and os.name != "nt":
            return
        import matplotlib.pyplot as plt

        if self._window is None:
            plt.ion()
            fig = plt.figure("bimrobot assembly")
            self._window = plt.imshow(frame)
            plt.axis("off")
            fig.tight_layout()
        else:
            self._window.set_data(frame)
        plt.pause(0.001)

    def close(self) -> None:
        if self._window is not None:
            import matplotlib.pyplot as plt

            plt.close("bimrobot assembly")
            self._window = None


ANSI_LEGEND = "C current, w waiting, # placed, t free target, X obstacle, F foundation, . ground"


def render_ansi(view: EpisodeView) -> str:
    """A top-down text map (x down, y across) with the top-most object of each (x, y) column."""
    sc = view.scenario
    W, L, _ = sc.grid
    grid = [["." for _ in range(L)] for _ in range(W)]
    height = np.full((W, L), -1)

    def mark(cells, char: str, priority: int) -> None:
        for x, y, z in cells:
            level = z * 10 + priority
            if level > height[x, y]:
                height[x, y] = level
                grid[x][y] = char

    for x, y in sc.foundations:
        mark([(x, y, 0)], "F", 1)
    for box in sc.obstacles:
        mark(box.cells(), "X", 2)
    for target, filled in zip(sc.targets, view.filled_targets):
        if not filled:
            mark(target.cells, "t", 0)
    for _cid, (state, cells) in view.components.items():
        mark(cells, {"current": "C", "waiting": "w"}.get(state, "#"), 5)
    lines = [
        f"{sc.name} step {view.elapsed}: moving {view.current or '-'} "
        f"({view.steps if view.current else 0} steps on it), {view.standing}/{view.total} standing",
        "     y " + "".join(str(y % 10) for y in range(L)),
    ]
    for x in range(W):
        lines.append(f"x {x:2d}  " + "".join(grid[x]))
    lines.append(ANSI_LEGEND)
    return "\n".join(lines) + "\n"


def write_gif(frames: list[np.ndarray], path, fps: float) -> None:
    """Save RGB frames as a looping GIF with one shared palette (fast: about 2 ms a frame).

    The palette is a median cut of a sample of the frames, with the state colours appended exactly, so
    small patches (the legend, a just-arrived component) keep their colour.
    """
    from PIL import Image

    sample = np.concatenate(frames[:: max(1, len(frames) // 12)], axis=0)
    base = Image.fromarray(sample).quantize(colors=256 - len(COLOURS), method=Image.Quantize.MEDIANCUT)
    palette = base.getpalette()[: 3 * (256 - len(COLOURS))]
    for colour in COLOURS.values():
        palette += [int(colour[i : i + 2], 16) for i in (1, 3, 5)]
    palette_image = Image.new("P", (1, 1))
    palette_image.putpalette(palette)
    images = [Image.fromarray(frame).quantize(palette=palette_image, dither=Image.Dither.NONE) for frame in frames]
    # the signature in a GIF comment: how bimrobot knows later that the file is its own to replace
    images[0].save(path, format="GIF", save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0,
                   comment=signature("assembly play animation"))
