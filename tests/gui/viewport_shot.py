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

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import plain_view, screenshot, view3d  # noqa: E402
from raylab.blender import overlay, probe, structure_cache  # noqa: E402

STRUCTURE = session.ARGS[1]
STEM = os.path.join(session.out_dir(), f"viewport_{STRUCTURE}")
report = {"structure": STRUCTURE}
SESSION = session.Session(STEM + ".json", report)


def set_up():
    scene = session.registered_scene_without_meshes()
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
        region=session.rect(region),
        points=points, edges=edges, line_color=list(scene.raylab.line_color),
    )
    result = probe.evaluate_probe(scene)
    hit = result["hit_point"] and location_3d_to_region_2d(region, rv3d, Vector(result["hit_point"]))
    report.update(status=result["status"], status_color=list(probe.STATUS_COLORS[result["status"]]),
                  hit_point=hit and (hit.x, hit.y), hit_color=list(probe.HIT_COLOR))


STEPS = session.Steps()


@STEPS
def shot_probe_off():
    describe()
    session.shoot_then_set(STEM + "_off.png", probe_enabled=True)


@STEPS
def shot_probe_on():
    screenshot(STEM + "_on.png")


SESSION.run(STEPS, set_up)
