"""Runs inside a real Blender window (xvfb-run, --enable-event-simulate): an artist's scene (a dense
sphere and 24 linked copies of Suzanne) under the octree, the sidebar on its raylab tab at its default
width; window screenshots of the boxes alone, of the boxes with the cost heat map, and of the Structure
panel with Colour by depth (its key) and the costliest objects. A JSON says where everything is.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup --enable-event-simulate START.blend \
        --python tests/gui/structure_panel_shot.py -- OUT_DIR

Writes OUT_DIR/structure_panel_boxes.png, _heat.png, _key.png, _probe.png (the camera's probe on) and
structure_panel.json: the regions, the heat map's cells with work, the depth key's colours, the panels'
text lines as text_fit wrapped them (with their measured and available widths), the ranking and the
probe's status; or "error".
"""
import os
import sys

import bpy
from mathutils import Euler

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import click_raylab_tab, plain_view, screenshot, show_sidebar, view3d  # noqa: E402
from raylab.blender import cost_overlay, overlay, probe, text_fit  # noqa: E402
from session import rect  # noqa: E402

STEM = os.path.join(session.out_dir(), "structure_panel")
report = {}
SESSION = session.Session(STEM + ".json", report)


def set_up():
    scene = session.registered_scene_without_meshes()
    bpy.ops.mesh.primitive_monkey_add(location=(0.0, 0.0, 0.0))
    base = bpy.context.active_object
    base.name = "Suzanne linked"
    for i in range(24):
        copy = base.copy()
        copy.location = ((i % 5) * 2.2 - 4.4, (i // 5) * 2.2, 0.0)
        scene.collection.objects.link(copy)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, location=(0.0, -3.0, 0.0))
    bpy.context.view_layer.objects.active = None  # no Item tab: the raylab tab is where click_raylab_tab looks
    for obj in scene.objects:
        obj.select_set(False)
    camera = scene.camera
    camera.location, camera.rotation_euler = (0.0, -14.0, 9.0), (1.0, 0.0, 0.0)
    settings = scene.raylab
    settings.structure, settings.max_depth = "octree", 4
    settings.show, settings.fade, settings.xray = True, False, True
    settings.cost_counter, settings.cost_cells = "triangle_tests", 64
    plain_view(Euler((1.0, 0.0, 0.0)), 16.0, location=(0.0, 2.0, 0.0))
    show_sidebar()


STEPS = session.Steps([click_raylab_tab])
WHEEL_STEPS = 12  # of the sidebar: past the Levels panel, the Structure panel's end in view


@STEPS
def shot_boxes():
    _, area, region, sidebar = view3d()
    report.update(region=rect(region), sidebar=rect(sidebar), line_color=list(bpy.context.scene.raylab.line_color))
    screenshot(STEM + "_boxes.png")
    bpy.context.scene.raylab.cost_enabled = True
    area.tag_redraw()


@STEPS
def shot_heat():
    _, area, region, _ = view3d()
    rv3d = area.spaces.active.region_3d
    grid = cost_overlay.cost_grid(bpy.context.scene, rv3d.perspective_matrix, region.width, region.height)
    report.update(cells=grid.counts.tolist())
    screenshot(STEM + "_heat.png")
    settings = bpy.context.scene.raylab
    settings.cost_enabled, settings.color_by_depth = False, True
    area.tag_redraw()


@STEPS
def scroll_to_the_structure_panels_end():
    """The Levels panel comes first: wheel the sidebar down, as a user does (simulated wheel events)."""
    window, _, _, sidebar = view3d()
    x, y = sidebar.x + sidebar.width // 2, sidebar.y + sidebar.height // 2
    window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=x, y=y)
    for _ in range(WHEEL_STEPS):
        window.event_simulate(type='WHEELDOWNMOUSE', value='PRESS', x=x, y=y)
    window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=40, y=y)  # no tooltip in the screenshots
    text_fit.RECORD = []


@STEPS
def shot_key():
    scene = bpy.context.scene
    screenshot(STEM + "_key.png")
    key = overlay.depth_key(scene.raylab, overlay.drawn_depths(scene))
    costs, why_not = cost_overlay.last_object_costs(scene)
    report.update(key=[(depth, [float(c) for c in colour]) for depth, colour in key],
                  lines=[list(entry) for entry in text_fit.RECORD], why_not=why_not,
                  ranked=[list(row) for row in costs.ranked()] if costs else None)
    settings = scene.raylab
    settings.probe_source, settings.probe_enabled = 'CAMERA', True  # the image's centre: the sphere
    text_fit.RECORD = []
    view3d().area.tag_redraw()


@STEPS
def shot_probe():
    screenshot(STEM + "_probe.png")
    report.update(probe_lines=[list(entry) for entry in text_fit.RECORD],
                  probe_text=list(probe.last_status_text(bpy.context.scene)),
                  probe_status=probe.evaluate_probe(bpy.context.scene)["status"])
    text_fit.RECORD = None


SESSION.run(STEPS, set_up)
