"""The overlay and the probe as a user sees them: Blender in a real window under Xvfb draws a mesh's
structure and the ray probe; the screenshots must show the boxes where Blender projects them, and
the status text in the top-left corner only when the probe is on.

Runs viewport_shot.py inside Blender; screenshots land in out/gui/.
"""
import os
import sys

import numpy as np
import pytest
from matplotlib.image import imread

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
OUT = os.path.join(ROOT, "out", "gui")
sys.path.insert(0, os.path.join(ROOT, "addon"))
import raylab  # noqa: E402
import gui_util  # noqa: E402


@pytest.fixture(scope="module")
def empty_blend(tmp_path_factory):
    """A saved default scene: opening a file keeps the splash screen out of the screenshots."""
    return gui_util.start_blend(tmp_path_factory.mktemp("viewport"))


def shoot(structure, blend):
    # --python-exit-code: a script that fails to start quits Blender instead of leaving the window open.
    report = gui_util.run_session("viewport_shot.py", f"viewport_{structure}.json", blend, [structure],
                                  outputs=(f"viewport_{structure}_off.png", f"viewport_{structure}_on.png"),
                                  extra=["--python-exit-code", "1"])
    off = imread(os.path.join(OUT, f"viewport_{structure}_off.png"))[:, :, :3]
    on = imread(os.path.join(OUT, f"viewport_{structure}_on.png"))[:, :, :3]
    return report, off, on


class Region:
    """The 3D viewport region inside the window screenshot (Blender counts y from the bottom)."""

    def __init__(self, report, image):
        r = report["region"]
        self.x, self.y, self.width, self.height = r["x"], r["y"], r["width"], r["height"]
        self.window_height = image.shape[0]

    def crop(self, image):
        top = self.window_height - (self.y + self.height)
        return image[top:top + self.height, self.x:self.x + self.width]

    def pixel(self, x, y):
        """(row, column) in a cropped region image of region coordinates (x, y)."""
        return self.height - 1 - int(round(y)), int(round(x))


def green_mask(image):
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return (g > 0.55) & (g - r > 0.3) & (g - b > 0.3)


def color_mask(image, color, tolerance=0.12):
    return np.all(np.abs(image - np.asarray(color[:3])) < tolerance, axis=-1)


def edge_samples(report, step=2.0):
    """Region-space points along every projected box edge."""
    points = report["points"]
    samples = []
    for a, b in report["edges"]:
        if points[a] is None or points[b] is None:
            continue
        pa, pb = np.array(points[a]), np.array(points[b])
        n = max(2, int(np.linalg.norm(pb - pa) / step))
        samples.append(pa + np.linspace(0.0, 1.0, n)[:, None] * (pb - pa))
    return np.concatenate(samples)


def dilate(mask, radius):
    out = mask.copy()
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            out |= np.roll(np.roll(mask, dy, axis=0), dx, axis=1)
    return out


def check_boxes_drawn(report, off):
    region = Region(report, off)
    green = green_mask(region.crop(off))
    samples = edge_samples(report)
    margin = 4
    inside = ((samples[:, 0] > margin) & (samples[:, 0] < region.width - margin)
              & (samples[:, 1] > margin) & (samples[:, 1] < region.height - margin))
    assert inside.sum() > 100, "the boxes should project into the viewport"
    near = dilate(green, 2)
    found = [near[region.pixel(x, y)] for x, y in samples[inside]]
    assert np.mean(found) > 0.9, f"only {np.mean(found):.0%} of the projected box edges are drawn green"

    expected = np.zeros_like(green)
    for x, y in samples[inside]:
        expected[region.pixel(x, y)] = True
    stray = green & ~dilate(expected, 5)
    assert green.sum() > 200
    assert stray.sum() <= 0.01 * green.sum(), f"{stray.sum()} green pixels lie away from every projected edge"


def check_status_text(report, off, on):
    region = Region(report, off)
    corner = (slice(0, 220), slice(0, 700))  # the top-left corner of the region
    text_on = color_mask(region.crop(on)[corner], report["status_color"]).sum()
    text_off = color_mask(region.crop(off)[corner], report["status_color"]).sum()
    assert text_on > 50, "the probe's status line is missing from the top-left corner"
    assert text_off < 5, "the status line is drawn although the probe is off"


def check_hit_dot(report, off, on):
    region = Region(report, off)
    assert report["hit_point"] is not None
    row, col = region.pixel(*report["hit_point"])
    window = (slice(row - 8, row + 9), slice(col - 8, col + 9))
    assert color_mask(region.crop(on)[window], report["hit_color"], 0.2).sum() > 10
    assert color_mask(region.crop(off)[window], report["hit_color"], 0.2).sum() == 0


@pytest.mark.parametrize("structure", [s for s, info in raylab.STRUCTURE_INFO.items() if info["has_boxes"]])
def test_overlay_and_probe_in_the_viewport(structure, empty_blend):
    report, off, on = shoot(structure, empty_blend)
    assert report["status"] == "hit_object"  # the ray object aims at the sphere
    check_boxes_drawn(report, off)
    check_status_text(report, off, on)
    check_hit_dot(report, off, on)


@pytest.fixture(scope="module")
def structure_panel(empty_blend):
    """structure_panel_shot.py: an artist's 26 objects under the octree, the sidebar at its default width."""
    report = gui_util.run_session("structure_panel_shot.py", "structure_panel.json", empty_blend,
                                  outputs=[f"structure_panel_{name}.png" for name in ("boxes", "heat", "key", "probe")],
                                  extra=["--enable-event-simulate"])
    images = {name: gui_util.load_rgb(os.path.join(OUT, f"structure_panel_{name}.png"))
              for name in ("boxes", "heat", "key")}
    return report, images


def worked_cells_mask(report, shape):
    """The region pixels under the heat map's cells that did work, left of the sidebar (which covers the
    view's right side) and clear of the legend in the bottom-left corner."""
    cells = np.array(report["cells"])
    rows, columns = cells.shape
    region = report["region"]
    height, width = shape
    ys, xs = np.mgrid[0:height, 0:width]
    cell_row = ((height - 1 - ys) * rows // height).clip(0, rows - 1)  # Blender's rows count from the bottom
    cell_column = (xs * columns // width).clip(0, columns - 1)
    mask = cells[cell_row, cell_column] > 0
    # a cell's one-pixel rim may blend with its neighbour: only the cells' insides
    mask &= ~gui_util.dilate(~mask, 2)
    mask[:, report["sidebar"]["x"] - region["x"] - 4:] = False
    mask[height - 90:, :260] = False
    return mask


def test_the_cost_heat_map_is_drawn_over_the_boxes(structure_panel):
    """Issue 27: with both on, the heat map was buried under the green boxes."""
    report, images = structure_panel
    region = gui_util.Region(report["region"], images["boxes"].shape[0])
    boxes, heat = region.crop(images["boxes"]), region.crop(images["heat"])
    cells = worked_cells_mask(report, boxes.shape[:2])
    assert cells.sum() > 20000
    assert green_mask(boxes)[cells].mean() > 0.3, "the boxes cover the object where the rays do work"
    assert green_mask(heat)[cells].mean() < 0.005, "the box lines show through the heat map's cells"
    # ... and those cells are the heat map's colours: several of them, the hottest pale yellow
    hot = gui_util.color_mask(heat, raylab.HEAT_COLOURS[-1], 0.08) & cells
    assert hot.sum() > 200
    assert green_mask(heat).sum() > 500, "the boxes still show around the cells"


def sidebar_crop(report, image):
    return gui_util.Region(report["sidebar"], image.shape[0]).crop(image)


def test_colour_by_depth_has_a_key_in_the_structure_panel_in_the_boxes_colours(structure_panel):
    report, images = structure_panel
    key = report["key"]
    assert [depth for depth, _ in key] == list(range(5))  # the octree of depth 4, every depth drawn
    key_sidebar, boxes_sidebar = sidebar_crop(report, images["key"]), sidebar_crop(report, images["boxes"])
    view = gui_util.Region(report["region"], images["key"].shape[0]).crop(images["key"])
    view = view[:, :report["sidebar"]["x"] - report["region"]["x"]]
    for depth, colour in key:
        swatch = gui_util.color_mask(key_sidebar, colour, 0.06).sum()
        assert swatch > 150, f"depth {depth}'s swatch is missing from the sidebar"
        assert gui_util.color_mask(boxes_sidebar, colour, 0.06).sum() < 10  # no key without Colour by depth
        # The boxes are drawn in the key's colours (a root's edges lie under its children's, drawn later).
        if depth > 0:
            assert gui_util.color_mask(view, colour, 0.06).sum() > 100, f"no box of depth {depth} in that colour"


def test_the_structure_panel_ranks_the_costliest_objects_in_lines_that_fit(structure_panel):
    report, _ = structure_panel
    lines = report["lines"]
    texts = [line for line, _, _ in lines]
    assert texts, "the panel drew no text through text_fit"
    too_wide = [(line, measured, room) for line, measured, room in lines if measured > room]
    assert not too_wide, f"lines wider than the sidebar: {too_wide}"
    text = " ".join(texts)
    ranked = report["ranked"]
    assert ranked[0][0] == "Sphere" and len(ranked) == 26
    assert "Costliest objects, by their share of the triangle tests of" in text
    shown = [name for name, _, _ in ranked[:5]]
    positions = [text.index(f"% {name}: ") for name in shown]  # each named, with its share, in rank order
    assert positions == sorted(positions)
    assert ranked[5][0] + ":" not in text and "and 21 more" in text
    # the per-object lines are wrapped, not elided: a line of the first object goes on in the next one
    assert any(line.startswith(f"{round(100 * ranked[0][2])}% Sphere:") and not line.endswith("ms")
               for line in texts)


def test_the_probe_panels_status_lines_fit_the_sidebar(structure_panel):
    report, _ = structure_panel
    assert report["probe_status"] == "hit_object" and len(report["probe_text"]) > 1
    parts = [part for line in report["probe_text"] for part in line.split(", ")]  # one count a row
    drawn = [line for line, _, _ in report["probe_lines"]]
    assert all(part in drawn for part in parts), (parts, drawn)
    assert all(measured <= room for _, measured, room in report["probe_lines"])
