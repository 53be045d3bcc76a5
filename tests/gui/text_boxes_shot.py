"""Runs inside a real Blender window (xvfb-run): File > New's scene without its cube, a Text object ("T",
extruded) and a collection instance of a monkey (its collection in no scene), seen from the front; the
BVH's boxes off, then on; then the probe aimed down onto the T's bar. Two window screenshots and a JSON
with the viewport region's place, the boxes the overlay drew and the probe's status.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup START.blend \
        --python tests/gui/text_boxes_shot.py -- OUT_DIR

Writes OUT_DIR/text_boxes_off.png, text_boxes_on.png and text_boxes.json ("error" in it if anything failed).
"""
import os
import sys

import bpy
import numpy as np
from mathutils import Euler, Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import plain_view, screenshot, view3d  # noqa: E402
from raylab.blender import probe, structure_cache  # noqa: E402

STEM = os.path.join(session.out_dir(), "text_boxes")
report = {}
SESSION = session.Session(STEM + ".json", report)


def set_up():
    scene = session.registered_scene_without_meshes()
    bpy.ops.object.text_add(location=(-1.5, 0.0, 0.0), rotation=(1.5708, 0.0, 0.0))
    text = bpy.context.object
    text.data.body = "T"
    text.data.extrude = 0.1
    props = bpy.data.collections.new("Props")
    bpy.ops.mesh.primitive_monkey_add()
    monkey = bpy.context.object
    for collection in list(monkey.users_collection):
        collection.objects.unlink(monkey)
    props.objects.link(monkey)
    bpy.ops.object.collection_instance_add(collection=props.name, location=(1.5, 0.0, 0.3))
    settings = scene.raylab
    settings.structure, settings.objects, settings.show = "bvh", 'ALL', False
    settings.probe_enabled = False
    plain_view(Euler((1.5708, 0.0, 0.0)), 8.0, location=(0.0, 0.0, 0.3))


def shot_off():
    report.update(region=session.rect(view3d()[2]))
    session.shoot_then_set(STEM + "_off.png", show=True)


def shot_on():
    screenshot(STEM + "_on.png")
    model = structure_cache.scene_model(bpy.context.scene)
    report.update(drawn={name: model.entry(name).box_count for name, _ in model.drawn()})
    # The probe straight down onto the T's bar (its top edge, in the middle).
    scene = bpy.context.scene
    text = scene.objects["Text"]
    evaluated = text.evaluated_get(bpy.context.evaluated_depsgraph_get())
    corners = np.array([tuple(text.matrix_world @ Vector(c)) for c in evaluated.bound_box])
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    ray = probe.ensure_probe_object(scene)
    ray.matrix_world = probe.aim_matrix(((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, hi[2] + 3.0), (0.0, 0.0, -1.0))
    scene.raylab.probe_enabled = True
    bpy.context.view_layer.update()
    report.update(probe=probe.evaluate_probe(scene)["status"], probe_text=probe.status_text(scene))


SESSION.run([shot_off, shot_on], set_up)
