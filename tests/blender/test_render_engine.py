"""The raylab render engine inside Blender: F12 renders, every structure gives the same picture, bad scenes
report an error without crashing, Esc cancels, and the comparison operator measures all four structures."""
import math
import os
import tempfile

import bpy
import numpy as np
import pytest

import raylab
from raylab.blender import default_scene, render_engine, scene_export

RESOLUTION = (120, 90)


@pytest.fixture
def demo_scene():
    scene = bpy.context.scene
    default_scene.build_default_scene(scene, resolution=RESOLUTION)
    scene.render.engine = 'RAYLAB'
    scene.raylab_render.structure = "bvh"
    scene.raylab_render.super_sampling = 1
    scene.pop("raylab_last_render", None)
    return scene


def render_f12(scene):
    """bpy.ops.render.render() as F12 does it; returns the Render Result as (H, W, 4) float, row 0 at the top."""
    scene.render.image_settings.file_format = 'OPEN_EXR'
    scene.render.image_settings.color_depth = '32'
    bpy.ops.render.render()
    with tempfile.TemporaryDirectory(prefix="raylab_render_") as folder:
        path = os.path.join(folder, "render.exr")
        bpy.data.images["Render Result"].save_render(path, scene=scene)
        image = bpy.data.images.load(path)
        pixels = np.array(image.pixels[:], np.float32).reshape(image.size[1], image.size[0], 4)[::-1]
        bpy.data.images.remove(image)
    return pixels


def test_f12_renders_the_object_and_reports_statistics(demo_scene, capfd):
    pixels = render_f12(demo_scene)
    printed = capfd.readouterr().out   # a background render prints Blender's render statistics line
    assert pixels.shape == (RESOLUTION[1], RESOLUTION[0], 4)
    background = np.array(scene_export.world_colour(demo_scene.world))
    middle = pixels[30:60, 40:80, :3]
    assert (np.abs(middle - background).max(axis=2) > 0.05).mean() > 0.5   # the goat fills the middle
    record = demo_scene["raylab_last_render"]
    assert record["structure"] == "bvh"
    assert record["rays_primary"] == RESOLUTION[0] * RESOLUTION[1]
    assert record["triangle_tests"] > 0 and record["rays_shadow"] > 0
    assert "| raylab bvh | build" in printed, printed[-2000:]


def test_every_structure_renders_the_same_image(demo_scene):
    images = {}
    for structure in raylab.STRUCTURES:
        demo_scene.raylab_render.structure = structure
        images[structure] = render_f12(demo_scene)
        assert demo_scene["raylab_last_render"]["structure"] == structure
    for structure in raylab.STRUCTURES[:-1]:
        assert np.array_equal(images[structure], images["bvh"]), structure


def test_bad_scenes_report_an_error_and_blender_keeps_running(demo_scene):
    camera = demo_scene.camera
    demo_scene.camera = None
    with pytest.raises(RuntimeError, match="camera"):     # Blender's own check comes first on F12
        bpy.ops.render.render()
    with pytest.raises(RuntimeError, match="no active camera"):
        bpy.ops.raylab.compare_structures()

    demo_scene.camera = camera
    vertices = bpy.data.objects["Goat Head"].data.vertices
    vertices[0].co = (math.nan, 0.0, 0.0)
    with pytest.raises(RuntimeError, match="Goat Head.*NaN"):
        bpy.ops.render.render()
    assert "raylab_last_render" not in demo_scene

    for obj in list(demo_scene.objects):
        if obj.type == 'MESH':
            bpy.data.objects.remove(obj)
    with pytest.raises(RuntimeError, match="no visible mesh"):
        bpy.ops.render.render()
    assert "raylab_last_render" not in demo_scene


def test_cancel_returns_cleanly(demo_scene, monkeypatch):
    # As if Esc was pressed (test_break() is True) at the first progress report; RNA methods such as
    # test_break itself cannot be replaced from Python.
    monkeypatch.setattr(render_engine.RaylabRenderEngine, "_progress", lambda self, fraction: True)
    bpy.ops.render.render()
    assert "raylab_last_render" not in demo_scene   # a cancelled render leaves no statistics

    # Mid-render: the slow structure, cancelled at the second progress report.
    demo_scene.render.resolution_x, demo_scene.render.resolution_y = 320, 240
    exported = scene_export.export_scene(bpy.context.evaluated_depsgraph_get())
    calls = []
    result = render_engine.render_exported(exported, demo_scene.raylab_render, structure="none",
                                           progress=lambda fraction: calls.append(fraction) or len(calls) > 1)
    assert result.cancelled and len(calls) == 2
    assert (result.image[..., 3] == 0).any()   # tiles never rendered keep zero colour and alpha


def test_comparison_operator_measures_all_four_structures(demo_scene):
    assert bpy.ops.raylab.compare_structures() == {'FINISHED'}
    table = demo_scene["raylab_comparison"]
    assert list(table.keys()) == list(raylab.STRUCTURES)
    assert len({table[s]["rays_primary"] for s in raylab.STRUCTURES}) == 1
    tests = {structure: table[structure]["triangle_tests"] for structure in raylab.STRUCTURES}
    assert tests["none"] > tests["aabb"] > max(tests["octree"], tests["bvh"])
    assert table["none"]["memory_bytes"] < min(table["octree"]["memory_bytes"], table["bvh"]["memory_bytes"])



def test_shade_smooth_renders_a_uv_sphere_without_facets(demo_scene):
    for name in ("Goat Head", "Ground"):
        bpy.data.objects.remove(demo_scene.objects[name])
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, radius=1.5, location=(0.0, 0.0, 1.5))
    sphere = bpy.context.active_object
    sphere.color = (0.8, 0.8, 0.8, 1.0)   # grey: its unlit side then differs from the background
    mesh = sphere.data
    background = np.array(scene_export.world_colour(demo_scene.world))

    def largest_step_across(pixels):
        """The largest brightness change between neighbouring sphere pixels on its widest row."""
        on_sphere = np.abs(pixels[..., :3] - background).max(axis=2) > 1e-3
        row = int(on_sphere.sum(axis=1).argmax())
        columns = np.flatnonzero(on_sphere[row])
        inner = pixels[row, columns[1]:columns[-1], :3].mean(axis=1)  # off the silhouette's step
        return np.abs(np.diff(inner)).max(), on_sphere

    flat_step, flat_silhouette = largest_step_across(render_f12(demo_scene))
    mesh.polygons.foreach_set("use_smooth", np.ones(len(mesh.polygons), bool))
    mesh.update()
    smooth_step, smooth_silhouette = largest_step_across(render_f12(demo_scene))
    assert smooth_silhouette.sum() > 500
    assert np.array_equal(smooth_silhouette, flat_silhouette)   # the same triangles, only shaded smooth
    assert smooth_step < 0.35 * flat_step, (smooth_step, flat_step)
