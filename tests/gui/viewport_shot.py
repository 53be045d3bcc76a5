"""Runs inside a real Blender window (xvfb-run): one mesh with the structure overlay on, two window
screenshots (probe off, probe on) and a JSON with what should be where.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup --python tests/gui/viewport_shot.py \
        -- OUT_DIR STRUCTURE

Writes OUT_DIR/viewport_STRUCTURE_off.png, ..._on.png and viewport_STRUCTURE.json: the 3D viewport
region's place in the window, the drawn boxes' corners projected into the region
(bpy_extras.view3d_utils.location_3d_to_region_2d) with their edges, the probe's status and text
colour, or "error" if anything failed.
"""
import os
import sys

import bpy
from bpy_extras.view3d_utils import location_3d_to_region_2d
from mathutils import Euler, Vector

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, os.pardir, os.pardir)
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, HERE)
import raylab  # noqa: E402
from blender_window import plain_view, run_steps, screenshot, view3d  # noqa: E402
from raylab.blender import overlay, probe, structure_cache  # noqa: E402

OUT_DIR, STRUCTURE = sys.argv[sys.argv.index("--") + 1:][:2]
os.makedirs(OUT_DIR, exist_ok=True)
STEM = os.path.join(OUT_DIR, f"viewport_{STRUCTURE}")
report = {"structure": STRUCTURE}


def set_up():
    raylab.register()
    scene = bpy.context.scene
    for obj in list(scene.objects):
        if obj.type == 'MESH':
            bpy.data.objects.remove(obj)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=1.5)
    settings = scene.raylab
    settings.structure = STRUCTURE
    settings.max_depth = 3
    settings.show = True
    settings.fade = False          # full-strength lines: the test looks for the line colour itself
    settings.color_by_depth = False
    settings.xray = True           # no box edge hidden behind the sphere
    probe.ensure_probe_object(scene)
    settings.probe_enabled = False
    plain_view(Euler((1.2, 0.0, 0.5)), 9.0)


def describe():
    """Where the drawn boxes lie, projected with the view the screenshots were taken with."""
    window, area, region, _ = view3d()
    rv3d = area.spaces.active.region_3d
    scene = bpy.context.scene
    points, edges = [], []
    for obj in structure_cache.target_objects(scene, bpy.context.view_layer):
        geometry = overlay.line_geometry(obj, scene)
        model = structure_cache.structure_for(obj, scene.raylab).model_matrix(obj)
        world = structure_cache.transform_points(model, geometry.positions.astype(float))
        base = len(points)
        for co in world:
            p = location_3d_to_region_2d(region, rv3d, Vector(co))
            points.append(None if p is None else (p.x, p.y))
        edges += [(base + int(a), base + int(b)) for a, b in geometry.indices]
    report.update(
        window_size=(window.width, window.height),
        region=dict(x=region.x, y=region.y, width=region.width, height=region.height),
        points=points, edges=edges, line_color=list(scene.raylab.line_color),
    )
    result = probe.evaluate_probe(scene)
    hit = result["hit_point"] and location_3d_to_region_2d(region, rv3d, Vector(result["hit_point"]))
    report.update(status=result["status"], status_color=list(probe.STATUS_COLORS[result["status"]]),
                  hit_point=hit and (hit.x, hit.y), hit_color=list(probe.HIT_COLOR))


STEPS = []


def step(function):
    STEPS.append(function)
    return function


@step
def shot_probe_off():
    describe()
    screenshot(STEM + "_off.png")
    bpy.context.scene.raylab.probe_enabled = True
    view3d().area.tag_redraw()


@step
def shot_probe_on():
    screenshot(STEM + "_on.png")


run_steps(set_up, STEPS, report, STEM + ".json")
