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

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, os.pardir, os.pardir, "addon"))
sys.path.insert(0, HERE)
import raylab  # noqa: E402
from blender_window import plain_view, run_steps, screenshot, view3d  # noqa: E402
from raylab.blender import cost_overlay  # noqa: E402

OUT_DIR = sys.argv[sys.argv.index("--") + 1]
os.makedirs(OUT_DIR, exist_ok=True)
STEM = os.path.join(OUT_DIR, "cost_overlay")
report = {}


def set_up():
    raylab.register()
    scene = bpy.context.scene
    for obj in list(scene.objects):
        if obj.type == 'MESH':
            bpy.data.objects.remove(obj)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=4, radius=1.5, location=(0.5, 0.0, 0.0))
    settings = scene.raylab
    settings.structure = "bvh"
    settings.show = False
    settings.cost_counter = "triangle_tests"
    settings.cost_maximum = 16
    settings.cost_cells = 64
    plain_view(Euler((1.2, 0.0, 0.5)), 9.0)


STEPS = []


def step(function):
    STEPS.append(function)
    return function


@step
def shot_off():
    screenshot(STEM + "_off.png")
    bpy.context.scene.raylab.cost_enabled = True
    view3d().area.tag_redraw()


@step
def shot_on():
    screenshot(STEM + "_on.png")
    window, area, region, _ = view3d()
    rv3d = area.spaces.active.region_3d
    obj = next(o for o in bpy.context.scene.objects if o.type == 'MESH')
    projected = [location_3d_to_region_2d(region, rv3d, obj.matrix_world @ v.co) for v in obj.data.vertices]
    grid = cost_overlay.cost_grid(bpy.context.scene, rv3d.perspective_matrix, region.width, region.height)
    report.update(region=dict(x=region.x, y=region.y, width=region.width, height=region.height),
                  sphere=[(p.x, p.y) for p in projected if p is not None],
                  columns=grid.columns, rows=grid.rows, cells_with_work=int((grid.counts > 0).sum()),
                  hardest=int(grid.counts.max()), legend=dict(origin=cost_overlay.LEGEND_ORIGIN, size=cost_overlay.LEGEND_SIZE))


run_steps(set_up, STEPS, report, STEM + ".json")
