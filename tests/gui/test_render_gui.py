"""F12 with the raylab engine in a real Blender window (under Xvfb): the render window shows the goat and
the statistics line. Runs with /usr/bin/python3 -m pytest tests/gui; writes out/gui/render_f12.png."""
import json
import os

import numpy as np
import pytest

import gui_util
from matplotlib import image as mpimg

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HERE = os.path.join(ROOT, "tests", "gui")
OUT = os.path.join(ROOT, "out", "gui")


@pytest.fixture(scope="module")
def f12_render():
    os.makedirs(OUT, exist_ok=True)
    blend = os.path.join(OUT, "demo_scene.blend")
    screenshot = os.path.join(OUT, "render_f12.png")
    report_path = os.path.join(OUT, "render_f12.json")
    for path in (blend, screenshot, report_path):
        if os.path.exists(path):
            os.remove(path)
    gui_util.demo_blend(blend)
    run = gui_util.run_watched(["xvfb-run", "-a", "-s", "-screen 0 1600x900x24", "blender", "--factory-startup",
                          blend, "--python-exit-code", "1", "--python", os.path.join(HERE, "render_f12.py"), "--",
                          screenshot, report_path],
                         capture_output=True, text=True, timeout=300)
    assert os.path.exists(report_path), run.stdout[-3000:] + run.stderr[-3000:]
    with open(report_path) as file:
        report = json.load(file)
    assert not report["errors"], report["errors"]
    pixels = (mpimg.imread(screenshot)[:, :, :3] * 255).astype(np.int32)   # row 0 = top of the window
    region = report["image_region"]
    top = pixels.shape[0] - (region["y"] + region["height"])
    return report, pixels[top:top + region["height"], region["x"]:region["x"] + region["width"]]


def test_render_window_shows_the_goat(f12_render):
    _, image_region = f12_render
    red, green, blue = image_region[..., 0], image_region[..., 1], image_region[..., 2]
    # The goat's orange-brown shading; Blender's UI, the ground and the background are grey or blue.
    goat = (red > 60) & (red - blue > 40) & (red > green)
    assert goat.mean() > 0.03, f"goat-coloured pixels: {goat.mean():.4f} of the render window"


def test_render_window_shows_the_raylab_statistics(f12_render):
    report, image_region = f12_render
    assert any(line.startswith("raylab bvh | build") for line in report["stats_sent"]), report["stats_sent"]
    assert report["last_render"]["structure"] == "bvh"
    # Blender draws the render's statistics as light text on a dark band across the top of the image:
    # its own part ("Frame:1 | Time:... | Mem:... (Peak ...)") ends near x = 310; raylab's line follows it.
    text = image_region[:24].mean(axis=2) > 170
    columns = np.flatnonzero(text.any(axis=0))
    assert text.sum() > 100 and text.mean() < 0.5, f"text pixels in the statistics band: {int(text.sum())}"
    assert columns.max() > 600, f"the statistics text ends at x = {columns.max()}"
