"""The viewport cost heat map as a user sees it: Blender in a real window under Xvfb, a sphere under the
BVH; with the heat map on, the view is coloured where the sphere projects and nowhere else, and the
legend is drawn. Runs cost_overlay_shot.py inside Blender; screenshots land in out/gui/."""
import os

import numpy as np
import pytest
from matplotlib.image import imread
import gui_util  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
OUT = os.path.join(ROOT, "out", "gui")


@pytest.fixture(scope="module")
def shots(tmp_path_factory):
    report = gui_util.run_session("cost_overlay_shot.py", "cost_overlay.json",
                                  gui_util.start_blend(tmp_path_factory.mktemp("cost")),
                                  outputs=("cost_overlay_off.png", "cost_overlay_on.png"),
                                  extra=["--python-exit-code", "1"])
    r = report["region"]
    images = []
    for suffix in ("_off.png", "_on.png"):
        image = imread(os.path.join(OUT, "cost_overlay" + suffix))[:, :, :3]
        top = image.shape[0] - (r["y"] + r["height"])
        images.append(image[top:top + r["height"], r["x"]:r["x"] + r["width"]])
    return report, images[0], images[1]


def region_rows(report, y):
    """Region pixel rows (top first, as the screenshot) of Blender's y counted from the bottom."""
    return report["region"]["height"] - 1 - np.asarray(y)


def test_heat_map_colours_where_the_sphere_projects(shots):
    report, off, on = shots
    changed = np.abs(on - off).max(axis=2) > 0.08
    (lx, ly), (lw, lh) = report["legend"]["origin"], report["legend"]["size"]
    changed[region_rows(report, ly + lh + 24):, :lx + lw + 80] = False  # the legend and its labels
    sphere = np.array(report["sphere"])
    cell = report["region"]["width"] / report["columns"]
    x0, y0 = sphere.min(axis=0) - 2 * cell
    x1, y1 = sphere.max(axis=0) + 2 * cell
    rows, cols = np.nonzero(changed)
    y = report["region"]["height"] - 1 - rows
    inside = (cols >= x0) & (cols <= x1) & (y >= y0) & (y <= y1)
    assert report["cells_with_work"] > 50 and report["hardest"] > 0
    assert changed.sum() > 2000, f"{changed.sum()} pixels changed by the heat map"
    assert inside.mean() > 0.98, f"{(~inside).sum()} coloured pixels lie away from the sphere"
    # ... and covers it: nearly every projected vertex has a coloured pixel within one cell
    near = [changed[max(0, r - int(cell)):r + int(cell) + 1, max(0, c - int(cell)):c + int(cell) + 1].any()
            for c, r in zip(sphere[:, 0].astype(int), region_rows(report, sphere[:, 1].astype(int)))]
    assert np.mean(near) > 0.9


def test_legend_is_drawn(shots):
    report, off, on = shots
    (lx, ly), (lw, lh) = report["legend"]["origin"], report["legend"]["size"]
    top, bottom = region_rows(report, ly + lh - 2), region_rows(report, ly + 2)
    bar_on, bar_off = on[top:bottom + 1, lx + 2:lx + lw - 2], off[top:bottom + 1, lx + 2:lx + lw - 2]
    assert np.abs(bar_on - bar_off).max(axis=2).mean() > 0.2
    # the bar runs from the coldest to the hottest colour: its two ends differ
    assert np.abs(bar_on[:, :8].mean(axis=(0, 1)) - bar_on[:, -8:].mean(axis=(0, 1))).max() > 0.3
