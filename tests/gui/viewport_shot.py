"""Runs inside a real Blender window (xvfb-run): one mesh with the structure overlay on, two window
screenshots (probe off, probe on) and a JSON with what should be where.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup --python tests/gui/viewport_shot.py \
        -- OUT_DIR STRUCTURE

Writes OUT_DIR/viewport_STRUCTURE_off.png, ..._on.png and viewport_STRUCTURE.json: the 3D viewport
region's place in the window, the drawn boxes' corners projected into the region
(bpy_extras.view3d_utils.location_3d_to_region_2d) with their edges, the probe's status and text
colour, or "error" if anything failed.
"""
import json
import os
import sys
import traceback

import bpy
from bpy_extras.view3d_utils import location_3d_to_region_2d
from mathutils import Euler, Vector

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir)
sys.path.insert(0, os.path.join(ROOT, "addon"))
import raylab  # noqa: E402
from raylab.blender import overlay, probe, structure_cache  # noqa: E402

OUT_DIR, STRUCTURE = sys.argv[sys.argv.index("--") + 1:][:2]
os.makedirs(OUT_DIR, exist_ok=True)
STEM = os.path.join(OUT_DIR, f"viewport_{STRUCTURE}")
report = {"structure": STRUCTURE}


def view3d():
    window = bpy.context.window_manager.windows[0]
    area = max((a for a in window.screen.areas if a.type == 'VIEW_3D'), key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == 'WINDOW')
    return window, area, region


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
    overlay.ensure_probe_object(scene)
    settings.probe_enabled = False

    _, area, region = view3d()
    space = area.spaces.active
    space.show_gizmo = False  # the navigation gizmo's green Y axis is not ours
    for flag in ("show_floor", "show_axis_x", "show_axis_y", "show_axis_z", "show_cursor",
                 "show_object_origins", "show_extras", "show_outline_selected"):
        setattr(space.overlay, flag, False)
    rv3d = space.region_3d
    rv3d.view_perspective = 'PERSP'
    rv3d.view_location = (0.0, 0.0, 0.0)
    rv3d.view_rotation = Euler((1.2, 0.0, 0.5)).to_quaternion()
    rv3d.view_distance = 9.0
    area.tag_redraw()


def screenshot(path):
    window, area, region = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.screen.screenshot(filepath=path)


def describe():
    """Where the drawn boxes lie, projected with the view the screenshots were taken with."""
    window, area, region = view3d()
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
    view3d()[1].tag_redraw()


@step
def shot_probe_on():
    screenshot(STEM + "_on.png")


def run_steps():
    try:
        STEPS.pop(0)()
        if STEPS:
            return 1.5
    except Exception:
        report["error"] = traceback.format_exc()
    with open(STEM + ".json", "w") as f:
        json.dump(report, f)
    bpy.ops.wm.quit_blender()
    return None


try:
    set_up()
    bpy.app.timers.register(run_steps, first_interval=2.0)
except Exception:
    report["error"] = traceback.format_exc()
    with open(STEM + ".json", "w") as f:
        json.dump(report, f)
    bpy.ops.wm.quit_blender()
