"""The demo scene: the goat head of the VRT thesis's timing trials on a ground plane, a point light, a camera.

The goat head (addon/raylab/meshes/goathead.obj, by hugoelec, CC BY 3.0, see goathead.README.md) is read
with raylab.load_mesh, so Blender holds exactly the triangles raylab measures.
"""
import math
import os

import bpy
import numpy as np

from .. import api
from . import compat
from .mesh_data import mesh_from_arrays, principled_material

GOAT_PATH = os.path.join(os.path.dirname(api.__file__), "meshes", "goathead.obj")
GOAT_SCALE = 0.25


def _add_object(scene, name, data, location=(0.0, 0.0, 0.0), rotation=(0.0, 0.0, 0.0)):
    obj = bpy.data.objects.new(name, data)
    obj.location = location
    obj.rotation_euler = rotation
    scene.collection.objects.link(obj)
    return obj


def build_default_scene(scene, resolution=(320, 240)):
    """Empty `scene` and build the demo in it; returns its objects by role."""
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    vertices, triangles = api.load_mesh(GOAT_PATH)
    goat = _add_object(scene, "Goat Head", mesh_from_arrays("goathead", vertices, triangles, smooth=True),
                       # The OBJ is Y-up: stand it up in Blender's Z-up world, turned three-quarters to the camera.
                       location=(0.0, 0.0, -float(vertices[:, 1].min()) * GOAT_SCALE),
                       rotation=(math.pi / 2, 0.0, math.radians(35.0)))
    goat.scale = (GOAT_SCALE,) * 3
    goat.data.materials.append(principled_material("Goat", (0.8, 0.55, 0.3), roughness=0.35))

    ground_mesh = mesh_from_arrays("ground", np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]) * 8.0,
                                   np.array([[0, 1, 2], [0, 2, 3]]))
    ground = _add_object(scene, "Ground", ground_mesh)
    ground.data.materials.append(principled_material("Ground", (0.5, 0.5, 0.55), roughness=0.6))

    light = _add_object(scene, "Light", bpy.data.lights.new("Light", 'POINT'), location=(4.0, -6.0, 7.0))
    light.data.energy = 2000.0
    light.data.shadow_soft_size = 0.1

    camera = _add_object(scene, "Camera", bpy.data.cameras.new("Camera"), location=(0.0, -11.0, 2.2),
                         rotation=(math.radians(88.0), 0.0, 0.0))
    scene.camera = camera

    if scene.world is None:
        scene.world = bpy.data.worlds.new("World")
    compat.set_world_colour(scene.world, (0.05, 0.07, 0.1))
    scene.render.resolution_x, scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    # raylab's image is linear light: show it through the plain sRGB transform, not Filmic.
    scene.view_settings.view_transform = 'Standard'
    return dict(goat=goat, ground=ground, light=light, camera=camera)
