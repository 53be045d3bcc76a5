"""Every level opened after another level, in a real Blender window under Xvfb: the level mesh is drawn
shaded, not as a black silhouette (issue 12: it stayed black until the object was moved); and Undo after
Open Level gives back the level before, drawn as well.

Runs tests/gui/level_switch_shots.py inside Blender; screenshots in out/gui/switch_*.png.
"""
import os

import numpy as np
import pytest

from gui_util import OUT, ROOT, Region, changed, load_rgb, run_session, start_blend

LEVELS_DIR = os.path.join(ROOT, "levels")
# The list's order matters little: each level after the one before it, the first after the user's scene.
LEVEL_IDS = sorted(d for d in os.listdir(LEVELS_DIR) if os.path.exists(os.path.join(LEVELS_DIR, d, "level.toml")))


@pytest.fixture(scope="module")
def shots(tmp_path_factory):
    return run_session("level_switch_shots.py", "level_switch.json", start_blend(tmp_path_factory.mktemp("switch")),
                       LEVEL_IDS, outputs=[f"switch_{name}{suffix}.png" for name in [*LEVEL_IDS, "undo"]
                                           for suffix in ("", "_hidden")])


def luminance(pixels):
    return pixels @ np.array([0.2126, 0.7152, 0.0722], np.float32)


def assert_shaded(entry, name, level_id):
    region = Region(entry["region"], entry["window_height"])
    shown, hidden = (region.crop(load_rgb(os.path.join(OUT, f"switch_{name}{s}.png"))) for s in ("", "_hidden"))
    mesh = changed(hidden, shown, threshold=0.05)
    mesh[:60] = False  # the header's text
    assert mesh.sum() > 2000, f"{level_id}: the level mesh covers almost no pixels"
    light = luminance(shown[mesh])
    # Solid shading with a material colour: lit and shadowed sides, never a black silhouette.
    assert np.median(light) > 0.15, f"{level_id}: the mesh is drawn dark (median luminance {np.median(light):.3f})"
    assert (light < 0.04).mean() < 0.1, f"{level_id}: {100 * (light < 0.04).mean():.0f} % of the mesh is black"


@pytest.mark.parametrize("level_id", LEVEL_IDS)
def test_the_level_mesh_is_shaded_not_black(shots, level_id):
    assert_shaded(shots["levels"][level_id], level_id, level_id)


def test_undo_after_open_level_gives_back_the_level_before(shots):
    undo = shots["undo"]
    assert undo["level"] == "aabb_1" and undo["level_scenes"] == 1 and not undo["mesh_hidden"]
    assert_shaded(undo, "undo", undo["level"])
