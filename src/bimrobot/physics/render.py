"""Offscreen pictures of a MuJoCo scene (MuJoCo's renderer on OSMesa or EGL: set ``MUJOCO_GL=osmesa``
or ``egl`` before MuJoCo is imported; Debian: ``apt-get install libosmesa6``)."""

from __future__ import annotations

from pathlib import Path


def render_png(model, data, path: str | Path, lookat, distance: float, azimuth: float, elevation: float,
               size: tuple[int, int] = (960, 720)) -> Path:
    """Draw ``data`` of ``model`` from a free camera (degrees; ``lookat`` world m) into a PNG file."""
    import mujoco
    from PIL import Image

    # clipping planes are fractions of the model's extent, which a 400 m ground slab makes large
    model.vis.map.znear = 0.02 / model.stat.extent
    model.vis.map.zfar = 200.0 / model.stat.extent
    renderer = mujoco.Renderer(model, size[1], size[0])
    try:
        camera = mujoco.MjvCamera()
        camera.lookat[:] = lookat
        camera.distance, camera.azimuth, camera.elevation = distance, azimuth, elevation
        renderer.update_scene(data, camera)
        Image.fromarray(renderer.render()).save(path)
    finally:
        renderer.close()
    return Path(path)
