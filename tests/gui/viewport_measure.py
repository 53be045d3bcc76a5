"""Measures what dragging the depth slider costs on a 100k-triangle mesh, in a real Blender window
(not a test: it prints figures, asserts nothing).

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup START.blend \
        --python tests/gui/viewport_measure.py -- MESH.obj [STRUCTURE] [--bounds]

Per depth 0..8: the structure build, the wireframe arrays, the GPU batch upload, the first redraw
(which builds both, as a slider drag does) and the redraw of the cached batch. --bounds draws
the mesh as its bounds, so that the redraw times are mostly the boxes'.
"""
import os
import sys
import time
import traceback

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import view3d  # noqa: E402
from raylab.blender import draw, overlay, structure_cache  # noqa: E402

ARGS = session.ARGS
MESH = ARGS[0]
STRUCTURE = ARGS[1] if len(ARGS) > 1 and not ARGS[1].startswith("--") else "octree"


def redraw_seconds(iterations):
    window, area, region, _ = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        start = time.perf_counter()
        bpy.ops.wm.redraw_timer(type='DRAW', iterations=iterations)
    return (time.perf_counter() - start) / iterations


def measure():
    scene = session.registered_scene_without_meshes()
    bpy.ops.wm.obj_import(filepath=MESH)
    obj = bpy.context.selected_objects[0]
    settings = scene.raylab
    settings.structure, settings.leaf_size, settings.fade = STRUCTURE, 8, True
    window, area, region, _ = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.view3d.view_selected()
    if "--bounds" in ARGS:
        obj.display_type = 'BOUNDS'  # software GL spends seconds on the mesh: leave the boxes' own cost
    depsgraph = bpy.context.evaluated_depsgraph_get()
    triangles = len(structure_cache.read_mesh(obj, depsgraph)[1])
    print(f"\n{os.path.basename(MESH)}: {triangles} triangles, structure {STRUCTURE}, leaf size 8")
    print("depth  boxes   build_ms  arrays_ms  upload_ms  first_redraw_ms  redraw_ms")
    settings.show = False
    empty = redraw_seconds(3)
    settings.show = True
    for depth in range(9):
        settings.max_depth = depth
        # What a slider step costs inside the draw callback: structure + arrays + upload + draw.
        first = redraw_seconds(1)
        redraw = redraw_seconds(3)
        # The parts, measured apart on a fresh cache.
        structure_cache.clear()
        start = time.perf_counter()
        entry = structure_cache.structure_for(obj, settings, depsgraph)
        built = time.perf_counter()
        overlay._geometry.clear()
        geometry = overlay.line_geometry(obj, scene, depsgraph)
        arrays = time.perf_counter()
        with bpy.context.temp_override(window=window, area=area, region=region):
            draw.make_batch('LINES', geometry.positions, geometry.colors, geometry.indices)
        uploaded = time.perf_counter()
        print(f"{depth:5d} {geometry.box_count:6d} {1000 * entry.structure.build_seconds:9.1f}"
              f" {1000 * (arrays - built):10.1f} {1000 * (uploaded - arrays):10.1f}"
              f" {1000 * first:16.1f} {1000 * redraw:10.1f}   (structure_for {1000 * (built - start):.1f} ms)")
    print(f"redraw without the boxes (show off): {1000 * empty:.1f} ms")


def run():
    try:
        measure()
    except Exception:
        traceback.print_exc()
    session.quit_blender()


bpy.app.timers.register(run, first_interval=1.0)
