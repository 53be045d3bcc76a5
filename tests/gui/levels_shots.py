"""Runs inside a real Blender window (xvfb-run): opens levels one after the other, lets the overlays
draw and takes window screenshots.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup START.blend \
        --python tests/gui/levels_shots.py -- OUT_DIR LEVEL_ID [LEVEL_ID ...]

For every level: OUT_DIR/level_ID.png (the level as it opens, with the Levels panel in the sidebar),
level_ID_boxes_off.png (the same view with the structure hidden) and, for levels with the probe,
level_ID_probe_off.png (the probe off too). OUT_DIR/levels_shots.json holds, per level, the 3D
viewport's and the sidebar's rectangles in the window, the level's boxes computed with raylab from
the level mesh and projected with bpy_extras.view3d_utils.location_3d_to_region_2d, and the probe's
status; or "error".
"""
import os
import sys

import bpy
import numpy as np
from bpy_extras.view3d_utils import location_3d_to_region_2d
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import click_raylab_tab, screenshot as window_screenshot, show_sidebar, view3d  # noqa: E402
from session import rect  # noqa: E402

OUT_DIR, LEVEL_IDS = session.out_dir(), session.ARGS[1:]
report = {"levels": {}}
SESSION = session.Session(os.path.join(OUT_DIR, "levels_shots.json"), report)
WATCHDOG_SECONDS = 240  # a window left open would keep the test waiting: quit with an error instead

import raylab  # noqa: E402
from raylab.blender import levels, probe  # noqa: E402
from raylab.blender.experiments import leak  # noqa: E402
BOX_EDGES = [(0, 1), (1, 3), (3, 2), (2, 0), (4, 5), (5, 7), (7, 6), (6, 4), (0, 4), (1, 5), (2, 6), (3, 7)]


def screenshot(name):
    window_screenshot(os.path.join(OUT_DIR, name))


def level_boxes(scene):
    """The boxes the overlay should draw, computed here from the level mesh with raylab itself:
    (B, 8, 3) world corners. AABB is the world box of the moved vertices; octree and BVH boxes are
    built in object space and carried by matrix_world, with the depth / leaves filters applied."""
    settings = scene.raylab
    obj = levels.level_mesh_object(scene)
    mesh = obj.data
    vertices = np.empty(3 * len(mesh.vertices), np.float32)
    mesh.vertices.foreach_get("co", vertices)
    vertices = vertices.reshape(-1, 3)
    matrix = np.array(obj.matrix_world)
    world = vertices @ matrix[:3, :3].T + matrix[:3, 3]
    if settings.structure == "aabb":
        lo, hi, keep, matrix = world.min(axis=0)[None], world.max(axis=0)[None], np.array([True]), np.identity(4)
    else:
        mesh.calc_loop_triangles()
        triangles = np.empty(3 * len(mesh.loop_triangles), np.int32)
        mesh.loop_triangles.foreach_get("vertices", triangles)
        structure = raylab.build(vertices, triangles.reshape(-1, 3).astype(np.uint32), structure=settings.structure,
                                 max_depth=settings.max_depth, leaf_size=settings.leaf_size)
        boxes = structure.boxes()
        lo, hi = boxes["lo"], boxes["hi"]
        keep = (boxes["depth"] >= settings.depth_min) & (boxes["depth"] <= settings.depth_max)
        if settings.leaves_only:
            keep &= boxes["leaf"]
    corners = np.stack([np.where([(i >> 2) & 1, (i >> 1) & 1, i & 1], hi[keep], lo[keep]) for i in range(8)], 1)
    return corners @ matrix[:3, :3].T + matrix[:3, 3]


def describe(level_id):
    window, area, region, sidebar = view3d()
    scene = bpy.context.scene
    rv3d = area.spaces.active.region_3d
    segments = []
    for box in level_boxes(scene):
        projected = [location_3d_to_region_2d(region, rv3d, Vector(c)) for c in box]
        segments += [((projected[a].x, projected[a].y), (projected[b].x, projected[b].y))
                     for a, b in BOX_EDGES if projected[a] is not None and projected[b] is not None]
    entry = dict(window_height=window.height, region=rect(region), sidebar=rect(sidebar),
                 structure=scene.raylab.structure, segments=segments, probe=scene.raylab.probe_enabled,
                 title=levels.find_level(level_id).title)
    if scene.raylab.probe_enabled:
        result = probe.evaluate_probe(scene)
        entry.update(status=result["status"], status_text=list(probe.status_text(scene)))
    report["levels"][level_id] = entry


def describe_leaks(level_id, contract=None, key="leak_segments"):
    """The escaped rays of the leak test (with `contract`: the BVH's under it), projected into the viewport as
    the overlay draws them, under report["levels"][level_id][key]."""
    _, area, region, _ = view3d()
    rv3d = area.spaces.active.region_3d
    starts, ends, _ = leak.leak_segments(bpy.context.scene, contract)
    segments = []
    for a, b in zip(starts, ends):
        pa, pb = location_3d_to_region_2d(region, rv3d, Vector(a)), location_3d_to_region_2d(region, rv3d, Vector(b))
        if pa is not None and pb is not None:
            segments.append(((pa.x, pa.y), (pb.x, pb.y)))
    report["levels"][level_id][key] = segments


def steps_for(level_id):
    """Each step runs in its own timer callback, so the window redraws in between."""

    def open_level():
        levels.open_level(bpy.context, level_id)
        bpy.context.scene.raylab.spin = False  # a still picture: the boxes must not move between shots
        show_sidebar()

    def shoot_level():
        describe(level_id)
        screenshot(f"level_{level_id}.png")
        bpy.context.scene.raylab.show = False

    def shoot_boxes_off():
        screenshot(f"level_{level_id}_boxes_off.png")
        bpy.context.scene.raylab.probe_enabled = False

    def shoot_probe_off():
        screenshot(f"level_{level_id}_probe_off.png")

    def count_leaks():
        bpy.ops.raylab.level_leak_test()

    def price_chart(key):
        scene = bpy.context.scene
        _, placed, chosen, _ = leak.price_chart_layout(scene[leak.LEAK_KEY], scene.raylab.contract)
        report["levels"][level_id][key] = dict(chosen=chosen, points={name: [x, y] for name, x, y, _ in placed},
                                               frame=list(leak.PRICE_FRAME))

    def shoot_leaks():
        describe_leaks(level_id)
        price_chart("price_chart")
        screenshot(f"level_{level_id}_leaks.png")
        bpy.context.scene.raylab.contract = "fast"  # the student switches the sidebar's Contract

    def shoot_leaks_fast():
        describe_leaks(level_id, "fast", "fast_contract_segments")
        price_chart("price_chart_fast")
        screenshot(f"level_{level_id}_leaks_fast.png")

    steps = [open_level, shoot_level, shoot_boxes_off]
    if levels.find_level(level_id).settings["raylab"].get("probe_enabled"):
        steps.append(shoot_probe_off)
    if level_id == "where_methods_fail":
        steps += [count_leaks, shoot_leaks, shoot_leaks_fast]
    return steps


STEPS = [step for level_id in LEVEL_IDS for step in steps_for(level_id)]
STEPS.insert(1, click_raylab_tab)  # once: the sidebar keeps its tab from level to level
SESSION.run(STEPS, raylab.register, watchdog_seconds=WATCHDOG_SECONDS, what="the shots")
