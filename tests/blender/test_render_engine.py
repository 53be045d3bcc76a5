"""The raylab render engine inside Blender: F12 renders, every structure gives the same picture, bad scenes
report an error without crashing, Esc cancels, and the comparison operator measures all four structures."""
import math
import os
import subprocess
import tempfile

import bpy
import numpy as np
import pytest

import raylab
from raylab.blender import compat, default_scene, render_engine, scene_export

RESOLUTION = (120, 90)
ADDON = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "addon")


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
    compat.set_file_format(scene.render.image_settings, 'OPEN_EXR')
    scene.render.image_settings.color_depth = '32'
    bpy.ops.render.render()
    with tempfile.TemporaryDirectory(prefix="raylab_render_") as folder:
        path = os.path.join(folder, "render.exr")
        bpy.data.images["Render Result"].save_render(path, scene=scene)
        image = bpy.data.images.load(path)
        pixels = np.array(image.pixels[:], np.float32).reshape(image.size[1], image.size[0], 4)[::-1]
        bpy.data.images.remove(image)
    return pixels


def test_f12_renders_the_object_and_reports_statistics(demo_scene):
    pixels = render_f12(demo_scene)
    assert pixels.shape == (RESOLUTION[1], RESOLUTION[0], 4)
    background = np.array(scene_export.world_colour(demo_scene.world))
    middle = pixels[30:60, 40:80, :3]
    assert (np.abs(middle - background).max(axis=2) > 0.05).mean() > 0.5   # the goat fills the middle
    record = demo_scene["raylab_last_render"]
    assert record["structure"] == "bvh"
    assert record["rays_primary"] == RESOLUTION[0] * RESOLUTION[1]
    assert record["triangle_tests"] > 0 and record["rays_shadow"] > 0


def test_a_command_line_render_prints_the_statistics_line(tmp_path):
    """`blender -b file -f 1` prints each frame's statistics line (3.x and 4.x on stdout after "Fra:1 Mem:",
    5.x through its log as "render | Fra: 1 | ..."): raylab's engine puts its own counts there. (5.x no
    longer prints it for bpy.ops.render.render() inside a script, so this runs a Blender of its own.)"""
    script = tmp_path / "scene.py"
    script.write_text(
        "import sys, bpy\n"
        f"sys.path.insert(0, {ADDON!r})\n"
        "import raylab\n"
        "raylab.register()\n"
        "from raylab.blender import default_scene\n"
        "scene = bpy.context.scene\n"
        "default_scene.build_default_scene(scene, resolution=(40, 30))\n"
        "scene.render.engine = 'RAYLAB'\n"
        f"scene.render.filepath = {str(tmp_path / 'frame_')!r}\n")
    run = subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", "--python-exit-code", "1",
                          "--python", str(script), "-f", "1"], capture_output=True, text=True, timeout=300)
    printed = run.stdout + run.stderr
    assert run.returncode == 0, printed[-2000:]
    line = next((line for line in printed.splitlines() if "| raylab bvh | build" in line), None)
    assert line is not None, printed[-2000:]
    assert "rays" in line and "triangle tests" in line, line


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


def test_esc_stops_a_long_brute_force_f12_mid_tile(demo_scene, monkeypatch):
    """Esc once the progress bar moves, in an F12 that takes minutes (brute force, 4x4 samples, the whole
    picture one tile): the render stops with few of its pixels done and leaves no statistics."""
    demo_scene.render.resolution_x, demo_scene.render.resolution_y = 400, 300
    props = demo_scene.raylab_render
    props.structure, props.super_sampling, props.tile_size = "none", 4, 512
    fractions, written = [], []

    def progress(self, fraction):  # test_break() turns True once some pixel is done
        fractions.append(fraction)
        return fraction > 0.0

    write = render_engine.RaylabRenderEngine._write_result

    def keep_result(self, result, view_layer):
        written.append(result)
        return write(self, result, view_layer)

    monkeypatch.setattr(render_engine.RaylabRenderEngine, "_progress", progress)
    monkeypatch.setattr(render_engine.RaylabRenderEngine, "_write_result", keep_result)
    bpy.ops.render.render()
    assert any(0.0 < f < 1.0 for f in fractions), "the progress bar moves while the one tile renders"
    (result,) = written
    assert result.cancelled
    done = int((result.image[..., 3] == 1.0).sum())
    assert 0 < done < result.image[..., 3].size // 10, f"{done} pixels rendered: the cancel did not stop the tile"
    assert "raylab_last_render" not in demo_scene


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


def test_in_a_level_f12_renders_the_structure_the_viewport_shows():
    """Issue 27, item 10: in BVH 2, switching the Structure panel to Octree left F12 on the BVH (a separate
    render setting), and a student comparing the two was misled. In a level F12 follows the viewport."""
    from raylab.blender import levels
    before = bpy.context.window.scene
    scene = levels.open_level(bpy.context, "bvh_2")
    try:
        scene.render.resolution_percentage = 10
        scene.raylab.structure = "octree"
        scene.raylab.max_depth_auto, scene.raylab.max_depth = False, 3
        bpy.ops.render.render()
        assert scene["raylab_last_render"]["structure"] == "octree"
        assert render_engine.structure_settings(scene) == scene.raylab
    finally:
        bpy.context.window.scene = before
        levels._remove_scene(scene)
    # Outside a level Render Properties keep their own structure.
    assert render_engine.structure_settings(before) == before.raylab_render
