"""The "Where does the work go?" level in a real Blender window under Xvfb: it opens, Render Heat Maps
runs as the student's button runs it (the modal job), the first task ticks, and a window shows the
picture: one heat map per structure side by side, separated, in the heat map's colours, brute force's
all the scale's last colour and the octree's mostly dark with bright outlines. Screenshots land in
out/gui/heat_maps_*.png.

Runs tests/gui/heat_maps_shots.py inside Blender (with --enable-event-simulate, to click the raylab tab).
"""
import os
import sys

import numpy as np
import pytest

from gui_util import OUT, ROOT, load_rgb, run_session, start_blend

sys.path.insert(0, os.path.join(ROOT, "addon"))
import raylab  # noqa: E402

SHOTS = ("heat_maps_picture.png", "heat_maps_window.png")


@pytest.fixture(scope="module")
def shots(tmp_path_factory):
    return run_session("heat_maps_shots.py", "heat_maps_shots.json", start_blend(tmp_path_factory.mktemp("heat_maps")),
                       outputs=SHOTS, extra=["--enable-event-simulate"])


def heat_distance(pixels):
    """How far each screen pixel is from the heat map's colour ramp (display sRGB, as shown)."""
    ramp = raylab.heat_map(np.linspace(0.0, 1.0, 512), 1.0)[:, :3]
    srgb = np.where(ramp <= 0.0031308, 12.92 * ramp, 1.055 * ramp ** (1 / 2.4) - 0.055)
    flat = pixels.reshape(-1, 3)
    distance = np.min(np.linalg.norm(flat[:, None, :] - srgb[None, :, :], axis=-1), axis=1)
    return distance.reshape(pixels.shape[:2])


def crop(image, rect, window_height, inset=3):
    """A map's rectangle (window pixels, y up) cut out of a window screenshot, a few pixels inside."""
    top = window_height - int(rect["y1"]) + inset
    bottom = window_height - int(rect["y0"]) - inset
    return image[top:bottom, int(rect["x0"]) + inset:int(rect["x1"]) - inset]


def test_the_level_opens_and_rendering_the_heat_maps_ticks_its_first_task(shots):
    assert shots["ticks"] == [True, False, False]
    assert list(shots["record"]["structures"]) == list(raylab.STRUCTURES)
    window = shots["window"]
    assert window["width"] >= 1200 and window["x"] >= 0  # in the main window, whole on the screen


def test_the_window_shows_one_map_per_structure_side_by_side(shots):
    image = load_rgb(os.path.join(OUT, "heat_maps_window.png"))
    maps = shots["maps"]
    height = shots["window_height"]
    assert len(maps) == len(raylab.STRUCTURES)
    widths = [m["x1"] - m["x0"] for m in maps]
    assert min(widths) > 60, f"the maps are too small to read: {widths} pixels wide"
    for left, right in zip(maps, maps[1:]):
        assert right["x0"] > left["x1"] + 2  # a gap between two maps
    # Read from the pixels: along the maps' middle row band, columns in the heat colours form one
    # run per map, separated by the gaps.
    top, bottom = height - int(maps[0]["y1"]), height - int(maps[0]["y0"])
    third = (bottom - top) // 3  # the middle rows: clear of the editor's corner buttons
    band = image[top + third:bottom - third, max(int(maps[0]["x0"]) - 20, 0):int(maps[-1]["x1"]) + 20]
    heat_columns = (heat_distance(band) < 0.08).mean(axis=0) > 0.95
    edges = np.flatnonzero(np.diff(heat_columns.astype(int)))
    runs = (len(edges) + 1) // 2
    assert runs == len(maps), f"{runs} runs of heat-coloured columns, {len(maps)} maps"


def test_each_map_has_its_numbers_written_under_it(shots):
    """Light text on the dark band under every map, several lines of it (structure, hardest, mean, total)."""
    image = load_rgb(os.path.join(OUT, "heat_maps_window.png"))
    for name, band in zip(shots["record"]["structures"], shots["bands"]):
        pixels = crop(image, band, shots["window_height"], inset=1)
        text = pixels.mean(axis=-1) > 0.6
        rows = np.flatnonzero(text.any(axis=1))
        assert text.sum() > 150, f"{name}: no numbers under its map"
        assert rows.max() - rows.min() > 0.6 * pixels.shape[0], f"{name}: fewer lines than expected"
    # Each map's own numbers: brute force's differ from the octree's.
    bands = [crop(image, b, shots["window_height"], inset=1).mean(axis=-1) > 0.6 for b in shots["bands"]]
    structures = list(shots["record"]["structures"])
    assert not np.array_equal(bands[structures.index("none")], bands[structures.index("octree")])


def test_each_map_shows_its_structure_s_work(shots):
    image = load_rgb(os.path.join(OUT, "heat_maps_window.png"))
    structures = list(shots["record"]["structures"])
    maximum = shots["record"]["maximum"]
    last = raylab.HEAT_COLOURS[-1]
    crops = {name: crop(image, rect, shots["window_height"]) for name, rect in zip(structures, shots["maps"])}
    for name, pixels in crops.items():
        assert (heat_distance(pixels) < 0.08).mean() > 0.95, f"{name}: not in the heat map's colours"
    # Brute force tests every triangle for every pixel, far over the scale: its map is the last colour.
    assert shots["record"]["structures"]["none"]["hardest"] > maximum
    assert np.abs(crops["none"] - last).max(axis=-1).mean() < 0.08
    # The octree skips most of the work: mostly dark, with bright places (the outlines, the rod).
    octree = crops["octree"].mean(axis=-1)
    assert (octree < 0.15).mean() > 0.5
    assert (octree > 0.4).sum() > 20
    # The maps' rectangles round to the window's pixels: two crops may differ by a pixel's width.
    h, w = (min(a, b) for a, b in zip(crops["octree"].shape[:2], crops["none"].shape[:2]))
    assert not np.allclose(crops["octree"][:h, :w], crops["none"][:h, :w], atol=0.1)


def test_the_heat_maps_editor_closes_with_its_level(shots):
    """Item 4 of issue 27: the Image Editor the heat maps split off the 3D viewport stayed over half of
    the next levels' viewport, showing maps without their numbers."""
    assert any(kind == 'IMAGE_EDITOR' for kind, _, _ in shots["areas_with_maps"])
    assert shots["level_after_next"] != "where_work_goes"
    assert shots["areas_after_next"] == shots["areas_before"], "the window's editors are not as they were"


def test_the_viewport_s_sidebar_stays_on_the_raylab_tab_with_the_tasks(shots):
    """Issue 42 item 6: with the sidebar on the raylab tab, Render Heat Maps split the viewport and left its
    sidebar on the Tool tab, the tasks hidden. After the maps the viewport's sidebar is still shown, on the
    raylab tab (it draws the level's Tasks panel; Blender 4.x and 5.x also name the tab), as tall as its
    viewport."""
    sidebar = shots["sidebar_after_maps"]
    assert sidebar["shown"]
    assert "Tasks" in sidebar["panels"], sidebar
    assert sidebar["category"] in (None, "raylab"), sidebar
    assert sidebar["height"] >= sidebar["area_height"] - 60, sidebar  # the viewport's header aside
