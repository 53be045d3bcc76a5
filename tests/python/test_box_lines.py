"""Structure.boxes(lines=True): the overlay's line arrays made in the core equal, value for value, what
the add-on's numpy code made from boxes() before (kept here as the reference), for every structure with
boxes, every filter and both colourings."""
import math

import numpy as np
import pytest

import raylab
from conftest import load

PALETTE = np.array([(1.00, 0.25, 0.20, 1.0), (1.00, 0.60, 0.10, 1.0), (0.95, 0.95, 0.15, 1.0),
                    (0.35, 1.00, 0.25, 1.0), (0.15, 0.95, 0.85, 1.0)], dtype=np.float32)
LINE = np.array([0.1, 0.8, 0.3, 0.9], dtype=np.float32)
CORNER_BITS = np.array([[(c >> axis) & 1 for axis in range(3)] for c in range(8)], dtype=bool)
EDGES = np.array([(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7),
                  (0, 4), (1, 5), (2, 6), (3, 7)], dtype=np.uint32)


def reference(boxes, depth_min, depth_max, leaves_only, palette, fade, alpha_scale):
    """The overlay's numpy version (overlay.py before the core made the arrays)."""
    depth = boxes["depth"]
    keep = (depth >= depth_min) & (depth <= depth_max)
    if leaves_only:
        keep &= boxes["leaf"]
    lo, hi, depth = boxes["lo"][keep], boxes["hi"][keep], depth[keep]
    corners = np.where(CORNER_BITS[None, :, :], hi[:, None, :], lo[:, None, :]).reshape(-1, 3)
    indices = (EDGES[None, :, :] + (8 * np.arange(len(lo), dtype=np.uint32))[:, None, None]).reshape(-1, 2)
    palette = np.asarray(palette, dtype=np.float32).reshape(-1, 4)
    rgba = palette[depth % len(palette)].copy()
    if fade:
        by_depth = 1.0 / (1.0 + 0.35 * depth.astype(np.float32))
        by_density = min(1.0, math.sqrt(200.0 / max(len(depth), 1)))
        rgba[:, 3] *= np.maximum(by_depth * by_density, 0.12)
    if alpha_scale != 1.0:
        rgba[:, 3] *= alpha_scale
    return corners.astype(np.float32), np.repeat(rgba, 8, axis=0), indices, int(keep.sum())


STRUCTURES = [s for s in raylab.STRUCTURES if raylab.STRUCTURE_INFO[s]["has_boxes"]]


@pytest.mark.parametrize("structure", STRUCTURES)
@pytest.mark.parametrize("depth_min, depth_max, leaves_only", [(0, None, False), (2, 3, False), (0, 64, True),
                                                               (5, 4, False)])
@pytest.mark.parametrize("palette, fade, alpha_scale", [(PALETTE, True, 1.0), (LINE, False, 1.0),
                                                        (LINE, True, 0.3), (PALETTE, False, 0.3)])
def test_lines_equal_the_numpy_overlay(structure, depth_min, depth_max, leaves_only, palette, fade, alpha_scale):
    vertices, triangles = load("goathead")
    s = raylab.build(vertices, triangles, structure=structure, max_depth=6)
    lines = s.boxes(lines=True, depth_min=depth_min, depth_max=depth_max, leaves_only=leaves_only,
                    palette=palette, fade=fade, alpha_scale=alpha_scale)
    upper = np.iinfo(np.int32).max if depth_max is None else depth_max
    positions, colors, indices, count = reference(s.boxes(), depth_min, upper, leaves_only, palette, fade,
                                                  alpha_scale)
    assert lines["box_count"] == count
    assert lines["positions"].dtype == np.float32 and lines["colors"].dtype == np.float32
    assert lines["indices"].dtype == np.uint32
    np.testing.assert_array_equal(lines["positions"], positions)
    np.testing.assert_array_equal(lines["colors"], colors)
    np.testing.assert_array_equal(lines["indices"], indices)


def test_bad_palette_is_a_value_error():
    vertices, triangles = load("goathead")
    s = raylab.build(vertices, triangles, structure="octree", max_depth=3)
    for bad in ([1.0, 0.0, 0.0], np.zeros((0, 4)), "red"):
        with pytest.raises(ValueError, match="palette"):
            s.boxes(lines=True, palette=bad)
    with pytest.raises(ValueError, match="depth_min"):
        s.boxes(lines=True, depth_min=1.5)
