"""A light's power as Cycles gives it: energy, times 2^exposure (4.5+), times the area of an area light whose
Normalize is off (4.5+). raylab's renderer is Whitted, not a path tracer, so the absolute brightness is
its own; what must agree is how a light's settings change it: the ratio of two renders of a white plane
under one area light, raylab's against Cycles' (CPU, 64 samples: within 8 %)."""
import os
import tempfile

import bpy
import numpy as np
import pytest

from raylab.blender import compat, mesh_data

TOLERANCE = 0.08


def plane_under_a_light(engine):
    scene = bpy.data.scenes.new(f"Light power {engine}")
    mesh = mesh_data.mesh_from_arrays("Plane", np.array([[-4, -4, 0], [4, -4, 0], [4, 4, 0], [-4, 4, 0]], np.float32),
                                      np.array([[0, 1, 2], [0, 2, 3]], np.uint32))
    plane = bpy.data.objects.new("Plane", mesh)
    plane.data.materials.append(mesh_data.principled_material("White", (0.8, 0.8, 0.8), roughness=1.0))
    scene.collection.objects.link(plane)
    light = bpy.data.objects.new("Light", bpy.data.lights.new("Light", 'AREA'))
    light.location = (0.0, 0.0, 2.0)  # an area light shines down its -Z
    light.data.energy = 100.0
    light.data.shape = 'SQUARE'
    light.data.size = 1.0
    scene.collection.objects.link(light)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, 0.0, 6.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.world = bpy.data.worlds.new("Black")
    compat.set_world_colour(scene.world, (0.0, 0.0, 0.0))
    scene.render.resolution_x = scene.render.resolution_y = 24
    scene.render.engine = engine
    if engine == 'CYCLES':
        scene.cycles.device = 'CPU'
        scene.cycles.samples = 64
        scene.cycles.use_denoising = False
        scene.cycles.max_bounces = 0  # direct light, as raylab's Whitted renderer computes it
    else:
        scene.raylab_render.super_sampling = 1
    scene.view_settings.view_transform = 'Standard'
    return scene, light.data


def brightness(scene):
    """The mean linear value of the image's middle (the plane right under the light)."""
    compat.set_file_format(scene.render.image_settings, 'OPEN_EXR')
    scene.render.image_settings.color_depth = '32'
    bpy.ops.render.render(scene=scene.name)
    with tempfile.TemporaryDirectory(prefix="raylab_light_") as folder:
        path = os.path.join(folder, "render.exr")
        bpy.data.images["Render Result"].save_render(path, scene=scene)
        image = bpy.data.images.load(path)
        pixels = np.array(image.pixels[:], np.float32).reshape(image.size[1], image.size[0], 4)
        bpy.data.images.remove(image)
    return float(pixels[8:16, 8:16, :3].mean())


def changes():
    """(name, change to the light) pairs this Blender has: energy always, exposure and normalize on 4.5+."""
    found = [("energy x 3", lambda light: setattr(light, "energy", light.energy * 3.0))]
    if "exposure" in bpy.types.Light.bl_rna.properties:
        found.append(("exposure 1.5", lambda light: setattr(light, "exposure", 1.5)))
    if "normalize" in bpy.types.Light.bl_rna.properties:
        def unnormalised(light):
            light.size = 2.0
            light.normalize = False
        found.append(("normalize off, 2 m square", unnormalised))
    return found


def ratio(engine, change, reference_size):
    scene, light = plane_under_a_light(engine)
    light.size = reference_size
    before = brightness(scene)
    change(light)
    after = brightness(scene)
    bpy.data.scenes.remove(scene)
    return after / before


@pytest.mark.parametrize("name, change", changes(), ids=[name for name, _ in changes()])
def test_a_lights_settings_change_raylabs_render_as_they_change_cycles(name, change):
    # The unnormalised light is compared with the normalised one of the same size (2 m): only the
    # setting differs, not where the light comes from.
    reference_size = 2.0 if "normalize" in name else 1.0
    cycles = ratio('CYCLES', change, reference_size)
    raylab_ratio = ratio('RAYLAB', change, reference_size)
    assert cycles > 1.5, (name, cycles)  # the change is one a user sees
    assert raylab_ratio == pytest.approx(cycles, rel=TOLERANCE), (name, raylab_ratio, cycles)
