"""The overlay and the probe follow an animated mesh: a grid with a Wave modifier, stepped frame by frame
with scene.frame_set. With animation_update 'REFIT' the BVH keeps its tree (node count, depths, leaves)
and its boxes follow the evaluated mesh; with 'REBUILD' it is built anew; either way the probe's hit lies
on the moved surface.

Run inside Blender: blender -b --factory-startup --python-expr "import pytest; pytest.main(['tests/blender'])"
"""
import os
import sys

import bpy
import numpy as np
import pytest
from mathutils import Vector

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "addon"))
from raylab.blender import overlay, probe, structure_cache  # noqa: E402

FRAMES = range(1, 9)
PROBE_XY = (0.3, -0.2)  # where the probe's ray comes down onto the grid (object = world space here)


@pytest.fixture
def wave_scene():
    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    structure_cache.clear()
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=24, y_subdivisions=24, size=2.0)
    grid = bpy.context.object
    wave = grid.modifiers.new("Wave", 'WAVE')
    wave.height, wave.width, wave.speed, wave.time_offset = 0.3, 0.8, 0.1, 0.0
    settings = scene.raylab
    settings.structure, settings.leaf_size, settings.objects = "bvh", 4, 'ALL'
    settings.probe_source, settings.fan_enabled, settings.probe_object = 'OBJECT', False, None
    settings.animation_update = 'REFIT'
    ray = probe.ensure_probe_object(scene)
    ray.matrix_world = probe.aim_matrix(Vector((*PROBE_XY, 3.0)), Vector((0.0, 0.0, -1.0)))
    scene.frame_set(FRAMES[0])
    bpy.context.view_layer.update()
    overlay.line_geometry(grid, scene)  # the scene model, built at the first frame
    yield scene, grid
    scene.frame_set(1)


def evaluated_vertices(obj):
    vertices, _ = structure_cache.read_mesh(obj, bpy.context.evaluated_depsgraph_get())
    return vertices


def surface_z(vertices, xy):
    """The height of the grid's surface at `xy`, near enough: the closest vertex's."""
    nearest = np.argmin(np.linalg.norm(vertices[:, :2] - np.asarray(xy), axis=1))
    return float(vertices[nearest, 2])


def played(scene, grid):
    """Steps through FRAMES; per frame: the entry's structure, its boxes, the drawn positions, the
    evaluated vertices and the probe's result."""
    out = []
    for frame in FRAMES:
        scene.frame_set(frame)
        geometry = overlay.line_geometry(grid, scene)
        entry = structure_cache.cached(grid, scene)
        out.append(dict(structure=entry.structure, boxes=entry.boxes(), drawn=geometry.positions.copy(),
                        vertices=evaluated_vertices(grid), probe=probe.evaluate_probe(scene)))
    return out


def test_refit_follows_the_wave_and_keeps_the_tree(wave_scene):
    scene, grid = wave_scene
    refits = structure_cache.stats["structure_refits"]
    frames = played(scene, grid)
    assert structure_cache.stats["structure_refits"] - refits == len(FRAMES) - 1  # every later frame refitted
    first = frames[0]["boxes"]
    for i, f in enumerate(frames):
        # The boxes follow the evaluated mesh: the root is its box.
        np.testing.assert_array_equal(f["boxes"]["lo"][0], f["vertices"].min(axis=0))
        np.testing.assert_array_equal(f["boxes"]["hi"][0], f["vertices"].max(axis=0))
        for field in ("depth", "leaf", "triangle_count"):  # the same tree
            np.testing.assert_array_equal(f["boxes"][field], first[field])
        assert f["structure"].refitted == (i > 0)
        if i > 0:  # the wave moved the mesh: other boxes drawn
            assert not np.array_equal(f["drawn"], frames[i - 1]["drawn"])
            assert not np.array_equal(f["vertices"], frames[i - 1]["vertices"])


def test_rebuild_builds_every_frame(wave_scene):
    scene, grid = wave_scene
    scene.raylab.animation_update = 'REBUILD'
    builds, refits = structure_cache.stats["structure_builds"], structure_cache.stats["structure_refits"]
    frames = played(scene, grid)
    assert structure_cache.stats["structure_refits"] == refits
    assert structure_cache.stats["structure_builds"] - builds == len(FRAMES) - 1
    for f in frames:
        assert not f["structure"].refitted
        np.testing.assert_array_equal(f["boxes"]["lo"][0], f["vertices"].min(axis=0))


@pytest.mark.parametrize("mode", ["REFIT", "REBUILD"])
def test_the_probe_hits_the_moved_surface(wave_scene, mode):
    scene, grid = wave_scene
    scene.raylab.animation_update = mode
    heights = []
    for f in played(scene, grid):
        assert f["probe"]["status"] == "hit_object"
        hit = f["probe"]["hit_point"]
        assert hit[:2] == pytest.approx(PROBE_XY, abs=1e-5)
        # On the surface between the nearest vertices (grid spacing 2/24: the wave moves them 0.3 at most).
        assert hit[2] == pytest.approx(surface_z(f["vertices"], PROBE_XY), abs=0.06)
        heights.append(hit[2])
    assert max(heights) - min(heights) > 0.01  # the surface moved under the probe, and the hit with it
