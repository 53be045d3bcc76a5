"""The probe's fan at its largest (64 x 64 = 4,096 rays) in a real Blender window under Xvfb: the fan is
drawn, and the mesh stays visible under it (issue 12: every ray drawn as a line covered the whole view).
Runs fan_shot.py inside Blender on the demo scene; the screenshots land in out/gui/fan_off.png, fan_on.png."""

import numpy as np
import pytest

import gui_util

# Of the goat's pixels with the fan off, the share that must look the same with the fan on. Measured on
# Blender 3.4: 0.87 with the fan drawn as raylab draws it (256 lines and a dot where each ray ends), 0.15
# with every ray drawn as a line (RAYLAB_FAN_ALL_LINES=1 in fan_shot.py), as before issue 12.
MESH_STILL_VISIBLE = 0.5


def goat_mask(rgb):
    """The goat's orange-brown shading; Blender's UI, the ground and the background are grey."""
    red, green, blue = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return (red > 0.24) & (red - blue > 0.16) & (red > green)


@pytest.fixture(scope="module")
def fan_shots(tmp_path_factory):
    blend = gui_util.demo_blend(str(tmp_path_factory.mktemp("fan") / "demo.blend"))
    return gui_util.off_on_shots("fan_shot.py", "fan", blend, extra=("--python-exit-code", "1"))


def test_the_fan_is_drawn_as_a_sample_of_lines(fan_shots):
    report, off, on = fan_shots
    assert report["fan_rays"] == 4096 and report["lines_drawn"] <= 256
    changed = np.any(np.abs(on - off) > 0.1, axis=-1)
    assert changed.sum() > 5000, "the fan is not drawn"


def test_the_status_text_has_a_dark_backdrop_and_the_fan_s_summary(fan_shots):
    """Issue 42 items 9 and 10: the probe's text in the top-left corner is drawn on a dark backdrop (over
    yellow boxes it was unreadable), and it holds the fan's summary line."""
    report, _, on = fan_shots
    assert any(line.startswith("fan of 4,096 rays, in all: triangle tests") for line in report["text"])
    x0, y0, x1, y1 = report["backdrop"]
    height = on.shape[0]
    box = on[height - int(y1):height - int(y0), int(x0):int(x1)]
    below = on[height - int(y0) + 10:height - int(y0) + 60, int(x0):int(x1)]  # the view just under it
    assert box.shape[0] > 40 and box.shape[1] > 200 and below.shape[0] == 50, (box.shape, below.shape)
    # Most of the box is backdrop, not text: its median pixel is far darker than the view's under it.
    inside, outside = float(np.median(box.max(axis=-1))), float(np.median(below.max(axis=-1)))
    assert inside < 0.5 * outside, (inside, outside)


def test_the_mesh_stays_visible_under_the_largest_fan(fan_shots):
    _, off, on = fan_shots
    goat = goat_mask(off)
    assert goat.sum() > 5000, "the goat is not in the view"
    unchanged = np.all(np.abs(on - off) < 0.06, axis=-1)  # the same colour as without the fan
    still = np.mean(unchanged[goat])
    assert still >= MESH_STILL_VISIBLE, f"only {still:.0%} of the goat's pixels still show it under the fan"
