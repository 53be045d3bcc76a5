"""The levels in a real Blender window under Xvfb: AABB 1, Octree 1 and Octree 2 open, their overlays
draw where the level's boxes project, the Levels panel shows the level, and Octree 2's probe writes its
status text in the top-left corner. Screenshots land in out/gui/level_*.png.

Runs tests/gui/levels_shots.py inside Blender (with --enable-event-simulate, to click the raylab tab).
"""
import os

import numpy as np
import pytest

from gui_util import OUT, Region, changed, dilate, load_rgb, run_session, segments_mask, start_blend

LEVELS = ("aabb_1", "octree_1", "octree_2")
LEAK_LEVEL = "where_methods_fail"  # shot before and after Count Leaking Rays


@pytest.fixture(scope="module")
def shots(tmp_path_factory):
    stale = [f"level_{level}{suffix}.png" for level in (*LEVELS, LEAK_LEVEL)
             for suffix in ("", "_boxes_off", "_probe_off", "_leaks", "_leaks_fast")]
    return run_session("levels_shots.py", "levels_shots.json", start_blend(tmp_path_factory.mktemp("levels")),
                       (*LEVELS, LEAK_LEVEL), outputs=stale, extra=["--enable-event-simulate"])["levels"]


def images(report, level_id, *suffixes):
    entry = report[level_id]
    region = Region(entry["region"], entry["window_height"])
    return region, [region.crop(load_rgb(os.path.join(OUT, f"level_{level_id}{s}.png"))) for s in suffixes]


def viewport_mask(entry, region, shape):
    """The part of the 3D viewport not covered by the sidebar, the header strip, the corner text and the
    leak test's price chart (where it was drawn)."""
    mask = np.zeros(shape, dtype=bool)
    sidebar_left = entry["sidebar"]["x"] - entry["region"]["x"]
    mask[60:, :sidebar_left] = True
    if "price_chart" in entry:
        x, y, w, h = entry["price_chart"]["frame"]
        top, left = region.row_col(x, y + h)
        mask[max(top - 2, 0):top + h + 3, max(left - 2, 0):left + w + 3] = False
    return mask


@pytest.mark.parametrize("level_id", LEVELS)
def test_the_overlay_is_drawn_where_the_level_boxes_project(shots, level_id):
    entry = shots[level_id]
    region, (on, off) = images(shots, level_id, "", "_boxes_off")
    inside = viewport_mask(entry, region, on.shape[:2])
    # A clear change: the viewport's anti-aliasing of the mesh outline varies a little between frames.
    drawn = changed(off, on, threshold=0.15) & inside
    assert drawn.sum() > 500, f"{level_id}: the overlay drew almost nothing"
    edges = segments_mask(region, entry["segments"], on.shape[:2])
    near_edges = dilate(edges, 3)
    # What the overlay drew lies on the projected box edges ...
    assert (drawn & near_edges).sum() / drawn.sum() > 0.9
    # ... and the projected edges are drawn (some run behind the mesh, which hides them without X-ray).
    visible_edges = edges & inside
    assert (visible_edges & dilate(drawn, 2)).sum() / visible_edges.sum() > 0.5


def test_octree_2_draws_the_probe_status_in_the_top_left_corner(shots):
    entry = shots["octree_2"]
    assert entry["status"] == "hit_object"  # the level starts with the ray on the bunny
    region, (probe_on, probe_off) = images(shots, "octree_2", "_boxes_off", "_probe_off")
    corner = (slice(0, 160), slice(0, 520))
    text = changed(probe_off[corner], probe_on[corner], threshold=0.25)
    assert text.sum() > 300, "no status text in the top-left corner"
    # The text has two lines: the status, and the counts.
    rows = np.flatnonzero(text.any(axis=1))
    assert rows.max() - rows.min() > 20
    assert any("/" in line for line in entry["status_text"]), entry["status_text"]


def test_the_levels_panel_shows_the_open_level(shots):
    """The sidebar changes from level to level: its title, goal, tasks and the start of its text fill
    the sidebar at its default width (the tasks sit under the goal; the diagrams follow further down)."""
    sidebars = []
    for level_id in LEVELS:
        entry = shots[level_id]
        full = load_rgb(os.path.join(OUT, f"level_{level_id}.png"))
        sidebar = Region(entry["sidebar"], entry["window_height"]).crop(full)
        sidebars.append(sidebar)
        # Text: light glyph pixels on the dark panels, spread over most of the sidebar's height.
        text_rows = np.flatnonzero((sidebar.mean(axis=-1) > 0.75).sum(axis=1) > 3)
        assert len(text_rows) > 150, f"{level_id}: little text in the Levels panel ({len(text_rows)} rows)"
        assert text_rows.max() - text_rows.min() > 0.6 * sidebar.shape[0], f"{level_id}: the text stops early"
    for a, b in zip(sidebars, sidebars[1:]):
        assert changed(a, b).mean() > 0.05


def test_count_leaking_rays_draws_the_escaped_rays_in_red(shots):
    entry = shots[LEAK_LEVEL]
    region, (before, after) = images(shots, LEAK_LEVEL, "_boxes_off", "_leaks")
    inside = viewport_mask(entry, region, after.shape[:2])
    drawn = changed(before, after, threshold=0.15) & inside

    def reddish(image):
        return (image[..., 0] > 0.6) & (image[..., 1] < 0.4) & (image[..., 2] < 0.4) & inside

    red = reddish(after) & ~reddish(before)  # the grid's x axis is red already
    assert red.sum() > 300, "no red rays in the viewport after Count Leaking Rays"
    # The new red lies on the escaped rays as the test projects them.
    rays = dilate(segments_mask(region, entry["leak_segments"], after.shape[:2]), 4)
    assert (red & rays).sum() / red.sum() > 0.9
    assert (drawn & rays).sum() / drawn.sum() > 0.8


def test_the_fast_contract_s_escaped_rays_turn_up_in_orange_and_its_point_is_ringed(shots):
    """Issue 42 item 7: switching the sidebar's Contract changed nothing in the viewport. Under the fast
    contract, the rays the BVH lets out are drawn in orange (the price chart's colour of the fast contract)
    where the test projects them; under the exact one there were none. On the price chart in the viewport's
    corner, the white ring moves from the exact contract's point to the fast one's."""
    entry = shots[LEAK_LEVEL]
    region, (exact, fast) = images(shots, LEAK_LEVEL, "_leaks", "_leaks_fast")
    inside = viewport_mask(entry, region, fast.shape[:2])

    def orange(image):
        return (image[..., 0] > 0.8) & (image[..., 1] > 0.3) & (image[..., 1] < 0.65) & (image[..., 2] < 0.25) & inside

    new = orange(fast) & ~orange(exact)
    assert new.sum() > 300, "no orange rays in the viewport after switching Contract to Fast"
    rays = dilate(segments_mask(region, entry["fast_contract_segments"], fast.shape[:2]), 4)
    assert (new & rays).sum() / new.sum() > 0.9
    for key, image, other in (("price_chart", exact, fast), ("price_chart_fast", fast, exact)):
        chart = entry[key]
        for name, (x, y) in chart["points"].items():
            top, left = region.row_col(x, y)
            ring = image[top - 11:top + 12, left - 11:left + 12]
            ring_pixels = (ring.min(axis=-1) > 0.9).sum()  # the ring: white, 17 px across, 2 px wide
            assert (ring_pixels > 40) == (name == chart["chosen"]), (key, name, ring_pixels)
