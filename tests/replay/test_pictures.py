"""The static pictures beside the replay: each is written and is a real picture, not an empty canvas."""

from __future__ import annotations

import numpy as np
import pytest

from bimrobot.cli import main


def assert_picture(path, min_size=(300, 200)):
    """``path`` is a PNG of at least ``min_size`` pixels with something drawn on it."""
    from PIL import Image

    assert path.is_file(), f"{path} was not written"
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert image.size[0] >= min_size[0] and image.size[1] >= min_size[1]
        pixels = np.asarray(image.convert("L"), dtype=float)
    assert pixels.std() > 10, f"{path} is (nearly) one colour"
    # more than a frame and a title: a share of the picture is not background
    assert (pixels < 200).mean() > 0.01


def test_convert_writes_a_preview_of_the_world(frame_build):
    import json

    assert_picture(frame_build / "package" / "preview.png")
    assert json.loads((frame_build / "package" / "report.json").read_text())["preview"] == "preview.png"


def test_gantt_of_the_build(frame_build):
    assert_picture(frame_build / "simulation" / "gantt.png")


def test_long_builds_get_hours_or_days_on_the_gantt_axis():
    from bimrobot.coordination.report import time_unit

    assert time_unit(1642.4) == (1.0, "s")
    assert time_unit(30 * 3600) == (3600.0, "h")
    assert time_unit(700_000) == (86400.0, "d")  # the Tekla build of the issue: 8.1 days, not 700,000 s


def test_allocators_draws_the_makespans(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["allocators", "generated:2x1x1", "--fleet", "fleet1", "--no-optimal", "--seeds", "1", "-o", "cmp"]) == 0
    assert_picture(tmp_path / "cmp" / "allocators.png", min_size=(300, 100))


@pytest.mark.slow
def test_rl_train_draws_its_learning_curve(tmp_path):
    pytest.importorskip("stable_baselines3")
    assert main(["rl", "train", "--setting", "E1S1", "--algo", "ppo", "--timesteps", "12000", "--eval-episodes", "1",
                 "--no-progress", "--threads", "1", "--profile", "fast", "-o", str(tmp_path)]) == 0
    curve = tmp_path / "E1S1-ppo-s0" / "learning_curve.png"
    assert_picture(curve)
    from PIL import Image

    rgb = np.asarray(Image.open(curve).convert("RGB"), dtype=int)
    line = (abs(rgb[..., 0] - 0x1F) < 40) & (abs(rgb[..., 1] - 0x77) < 40) & (abs(rgb[..., 2] - 0xB4) < 40)
    assert line.sum() > 200, "the smoothed return line (matplotlib's first colour) is not drawn"
