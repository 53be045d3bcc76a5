"""Where does the work go: Render Heat Maps and its level, as a student does them. The numbers the
panel shows are the API's (every pixel's camera ray traced again with intersect(per_ray=True)), the
picture is heat_map of them on one scale, and the level's tasks tick when they are done, not before.

Run inside Blender: blender -b --factory-startup --python-expr "import pytest; pytest.main(['tests/blender'])"
"""
import os
import sys

import bpy
import numpy as np
import pytest

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir)
sys.path.insert(0, os.path.join(ROOT, "addon"))
import raylab  # noqa: E402
from raylab.blender import build_settings, compare, heat_maps, levels, scene_export  # noqa: E402

LEVEL = "where_work_goes"


@pytest.fixture(scope="module")
def level_scene():
    before = bpy.context.window.scene
    scene = levels.open_level(bpy.context, LEVEL)
    yield scene
    bpy.context.window.scene = before
    for s in [s for s in bpy.data.scenes if levels.state(s) is not None]:
        levels._remove_scene(s)


@pytest.fixture(scope="module")
def rendered(level_scene):
    """The level's heat maps, rendered once for the tests that read them."""
    assert bpy.ops.raylab.heat_maps(time_limit=0.0) == {'FINISHED'}
    return record(level_scene)


def ticks(scene):
    """The Tasks panel's ticks after the add-on's timer looked (a render fires no depsgraph update)."""
    bpy.context.view_layer.update()
    levels._check_timer()
    return [done for _, done in levels.task_list(scene)]


def pixel_costs(scene, structure):
    """Every map pixel's triangle tests, traced again through the API: the camera ray of each pixel
    (raylab.camera_rays) with intersect(per_ray=True) on the scene built as the job builds it."""
    exported = scene_export.export_scene(bpy.context.evaluated_depsgraph_get())
    props = scene.raylab_render
    model, _ = scene_export.build_scene(exported, **build_settings.build_kwargs(props, structure))
    camera = heat_maps.heat_map_camera(exported.camera)
    width, height = raylab.image_size(camera)
    pixels = np.stack(np.meshgrid(np.arange(width), np.arange(height)), axis=-1).reshape(-1, 2) + 0.5
    origins, directions = raylab.camera_rays(camera, pixels)
    hits = model.intersect(origins, directions, per_ray=True)
    return hits.per_ray[heat_maps.COUNTER].reshape(height, width)


def record(scene):
    return scene[heat_maps.RECORD].to_dict()


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_each_map_s_numbers_are_the_api_s(level_scene, rendered, structure):
    scene = level_scene
    numbers = rendered["structures"][structure]
    counts = pixel_costs(scene, structure)
    x, y = numbers["pixel"]
    assert numbers["hardest"] == counts.max() == counts[y, x]
    assert (y, x) == np.unravel_index(np.argmax(counts), counts.shape)  # the first hardest, row by row
    assert numbers["total"] == counts.sum(dtype=np.float64)
    assert numbers["mean"] == pytest.approx(counts.mean(), rel=1e-6)
    if structure == "none":  # brute force: every ray tests every triangle, the map is flat
        triangles = sum(len(o.data.polygons) for o in scene.objects if o.type == 'MESH')
        assert counts.min() == counts.max() == triangles


def test_the_picture_is_every_map_on_one_scale_and_the_legend(level_scene, rendered):
    scene = level_scene
    numbers = rendered
    width, height = numbers["size"]
    n = len(raylab.STRUCTURES)
    maximum = numbers["maximum"]
    assert maximum == scene.raylab_render.heat_maps_scale == 120  # the level's scale: every map on it
    image = bpy.data.images[heat_maps.IMAGE_NAME]
    legend = raylab.heat_legend(maximum, width=n * width + (n - 1) * heat_maps.GAP)
    assert tuple(image.size) == (n * width + (n - 1) * heat_maps.GAP, height + heat_maps.NUMBER_BAND + len(legend))
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    picture = pixels.reshape(image.size[1], image.size[0], 4)[::-1]  # row 0 the top
    for i, structure in enumerate(raylab.STRUCTURES):
        left = i * (width + heat_maps.GAP)
        shown = picture[:height, left:left + width]
        expected = raylab.heat_map(pixel_costs(scene, structure), maximum)
        np.testing.assert_allclose(shown, expected, atol=1e-6)
    np.testing.assert_allclose(picture[-len(legend):], legend, atol=1e-6)


def test_without_a_scale_the_scale_is_the_hardest_pixel_of_all_the_maps():
    costs = {"none": np.full((2, 3), 7.0, np.float32), "bvh": np.array([[0, 1, 9], [2, 0, 0]], np.float32)}
    results = [compare.StructureResult(name, stats={}, cost={heat_maps.COUNTER: c}) for name, c in costs.items()]
    results.append(compare.StructureResult("aabb", note="skipped: too slow"))
    numbers = heat_maps.heat_record(results, (6, 4))
    assert numbers["maximum"] == 9 and heat_maps.heat_record(results, (6, 4), scale=5)["maximum"] == 5
    assert numbers["structures"]["bvh"] == dict(hardest=9, pixel=[2, 0], probe_pixel=[5, 1], mean=2.0, total=12.0)
    assert numbers["structures"]["none"]["pixel"] == [0, 0]  # a flat map: the first pixel
    assert numbers["skipped"] == {"aabb": "skipped: too slow"} and numbers["size"] == [3, 2]


def test_a_scene_without_a_camera_is_refused_with_a_reason(level_scene):
    scene = level_scene
    camera = scene.camera
    scene.camera = None
    try:
        with pytest.raises(RuntimeError, match="no active camera"):
            bpy.ops.raylab.heat_maps(time_limit=0.0)
    finally:
        scene.camera = camera


def test_every_structure_skipped_stores_no_record_and_says_why(level_scene, rendered):
    scene = level_scene
    before = scene[heat_maps.RECORD].to_dict() if heat_maps.RECORD in scene else None
    job = heat_maps.new_job(bpy.context, time_limit=1e-9)  # every estimate is over the limit
    job.run()
    assert job.error is None and all(r.cost is None and "skipped" in r.note for r in job.results)
    with pytest.raises(ValueError, match="no structure was rendered"):
        heat_maps.finish(bpy.context, job)
    after = scene[heat_maps.RECORD].to_dict() if heat_maps.RECORD in scene else None
    assert after == before


def test_the_job_is_compare_structures_job_with_camera_rays_only(level_scene):
    job = heat_maps.new_job(bpy.context, time_limit=0.0)
    assert isinstance(job, compare.CompareJob) and job.structures == raylab.STRUCTURES
    assert job.settings["cost_rays"] == heat_maps.COST_RAYS and job.settings["super_sampling"] == 1
    width, height = raylab.image_size(job.exported.camera)
    assert width * height <= heat_maps.HEAT_MAP_PIXELS


def test_the_level_s_tasks_tick_as_the_student_does_them(level_scene):
    scene = levels.open_level(bpy.context, LEVEL)  # from scratch: nothing rendered yet
    assert ticks(scene) == [False, False, False]
    assert "Rod" in scene.objects  # the level's [[objects]]

    # (a) Render the heat maps.
    assert bpy.ops.raylab.heat_maps(time_limit=0.0) == {'FINISHED'}
    assert ticks(scene) == [True, False, False]
    first = record(scene)
    assert list(first["structures"]) == list(raylab.STRUCTURES)  # every structure, in the menu's order
    assert first["size"] == first["render_size"] == [scene.render.resolution_x, scene.render.resolution_y]

    # (b) The probe far from the octree's hardest pixel does not tick; on it, it does, and the probe's
    # own count (the same camera ray through the same octree) is the map's number.
    octree = first["structures"]["octree"]
    x, y = octree["probe_pixel"]
    scene.raylab.probe_pixel_x, scene.raylab.probe_pixel_y = (x + 40) % 160, (y + 40) % 120
    assert ticks(scene) == [True, False, False]
    scene.raylab.probe_pixel_x, scene.raylab.probe_pixel_y = x + 2, y - 1
    assert ticks(scene) == [True, True, False]
    scene.raylab.probe_pixel_x, scene.raylab.probe_pixel_y = x, y
    assert scene.raylab.structure == "octree"
    assert scene.raylab.probe_triangle_tests == octree["hardest"]

    # (c) Rendering again without a change is no cheaper; moving the rod off the goat is.
    assert bpy.ops.raylab.heat_maps(time_limit=0.0) == {'FINISHED'}
    assert ticks(scene) == [True, True, False]
    scene.objects["Rod"].location.x += 1.5
    assert ticks(scene) == [True, True, False]  # moved, not rendered yet
    assert bpy.ops.raylab.heat_maps(time_limit=0.0) == {'FINISHED'}
    assert ticks(scene) == [True, True, True]
    assert record(scene)["structures"]["bvh"]["hardest"] < first["structures"]["bvh"]["hardest"]


def test_the_map_s_counter_and_rays_are_the_core_s_names():
    assert heat_maps.COUNTER in raylab.COUNTERS and heat_maps.COST_RAYS in raylab.COST_RAYS
    assert heat_maps.counter_label() == next(p["label"] for p in raylab.COST_PASS_INFO.values()
                                             if p["counter"] == heat_maps.COUNTER)
