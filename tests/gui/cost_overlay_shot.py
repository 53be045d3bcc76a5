"""Runs inside a real Blender window (xvfb-run): a sphere under the BVH, two window screenshots with the
cost heat map off and on, and a JSON with where the sphere projects and what the heat map traced.

    xvfb-run -a -s "-screen 0 1600x900x24" blender START.blend --python tests/gui/cost_overlay_shot.py -- OUT_DIR

Writes OUT_DIR/cost_overlay_off.png, cost_overlay_on.png and cost_overlay.json (or "error" in it).
"""
import os
import sys

import bpy
from bpy_extras.view3d_utils import location_3d_to_region_2d
from mathutils import Euler

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import plain_view, screenshot, view3d  # noqa: E402
from raylab.blender import cost_overlay  # noqa: E402

STEM = os.path.join(session.out_dir(), "cost_overlay")
report = {}
SESSION = session.Session(STEM + ".json", report)


def set_up():
    scene = session.registered_scene_without_meshes()
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=4, radius=1.5, location=(0.5, 0.0, 0.0))
    settings = scene.raylab
    settings.structure = "bvh"
    settings.show = False
    settings.cost_counter = "triangle_tests"
    settings.cost_maximum = 16
    settings.cost_cells = 64
    plain_view(Euler((1.2, 0.0, 0.5)), 9.0)


STEPS = session.Steps()


@STEPS
def shot_off():
    session.shoot_then_set(STEM + "_off.png", cost_enabled=True)


@STEPS
def shot_on():
    screenshot(STEM + "_on.png")
    window, area, region, _ = view3d()
    rv3d = area.spaces.active.region_3d
    obj = next(o for o in bpy.context.scene.objects if o.type == 'MESH')
    projected = [location_3d_to_region_2d(region, rv3d, obj.matrix_world @ v.co) for v in obj.data.vertices]
    grid = cost_overlay.cost_grid(bpy.context.scene, rv3d.perspective_matrix, region.width, region.height)
    report.update(region=session.rect(region),
                  sphere=[(p.x, p.y) for p in projected if p is not None],
                  columns=grid.columns, rows=grid.rows, cells_with_work=int((grid.counts > 0).sum()),
                  hardest=int(grid.counts.max()),
                  legend=dict(origin=cost_overlay.LEGEND_ORIGIN, size=cost_overlay.LEGEND_SIZE))


SESSION.run(STEPS, set_up)
