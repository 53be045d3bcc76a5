"""The evaluated Blender scene as the raylab renderer's inputs: meshes, instances, materials, camera, lights.

Meshes come from the evaluated depsgraph (modifiers applied). Instances of one mesh share ONE raylab mesh:
objects that use the same mesh datablock without modifiers, and collection or geometry instances, all point
at the same evaluated mesh, so that mesh is exported, and its structure built, once.
"""
import math
from dataclasses import dataclass, field

import numpy as np

from .. import api
from . import compat, scene_geometry

from .mesh_data import corner_normals, mesh_triangles, mesh_vertices

# Blinn-Phong exponent equivalent to a GGX roughness r (alpha = r^2, n = 2 / alpha^2 - 2; Walter et al.
# 2007, Karis 2013), clamped so a roughness of 0 stays finite and a rough surface keeps a faint highlight.
SHININESS_RANGE = (1.0, 1000.0)


class ExportError(ValueError):
    """The scene cannot be rendered; the message says why and what to do."""


@dataclass
class Instance:
    mesh: int            # index into ExportedScene.meshes
    matrix: np.ndarray   # (4,4) float64 row-major object -> world
    material: int        # index into ExportedScene.materials
    object_name: str     # the geometry's name (scene_geometry.MeshInstance.source)


@dataclass
class ExportedScene:
    meshes: list = field(default_factory=list)       # [(V (n,3) float32, T (m,3) uint32)]
    normals: list = field(default_factory=list)      # per mesh: (m,3,3) float32 corner normals, object space
    instances: list = field(default_factory=list)    # [Instance]
    materials: list = field(default_factory=list)    # renderer material dicts
    lights: list = field(default_factory=list)       # renderer light dicts
    camera: dict = None
    background: tuple = (0.0, 0.0, 0.0)


def export_scene(depsgraph):
    """Export the evaluated scene of `depsgraph`; raises ExportError when it cannot be rendered."""
    scene = depsgraph.scene
    exported = ExportedScene(camera=export_camera(depsgraph))
    mesh_index = {}        # evaluated mesh pointer -> index in exported.meshes
    material_index = {}    # material name or object colour -> index
    for instance in depsgraph.object_instances:
        if instance.object.type == 'LIGHT' and (instance.is_instance or instance.show_self):
            exported.lights.append(_light(instance.object.data, instance.matrix_world))
    # The viewport's scene model reads the same instances (scene_geometry): what F12 renders is what the
    # boxes, the probe and "Costliest objects" see.
    for instance in scene_geometry.mesh_instances(depsgraph):
        obj = instance.obj
        # Instances of one evaluated mesh (one datablock without modifiers, a collection's object, a
        # geometry nodes' instance) share its pointer: the mesh is exported, and its structure built, once.
        key = instance.mesh.as_pointer()
        if key not in mesh_index:
            arrays = _mesh_arrays(instance.mesh, instance.source)
            if arrays is None:
                continue
            mesh_index[key] = len(exported.meshes)
            exported.meshes.append(arrays)
            exported.normals.append(corner_normals(instance.mesh))
        material = _material_slot(obj, material_index, exported.materials)
        exported.instances.append(Instance(mesh_index[key], instance.matrix, material, instance.source))
    if not exported.instances:
        raise ExportError("Nothing to render: the scene has no visible mesh object with faces")
    exported.background = world_colour(scene.world)
    return exported


def export_camera(depsgraph):
    """The renderer's camera dict for the scene camera, evaluated (see camera_dict)."""
    scene = depsgraph.scene
    if scene.camera is None:
        raise ExportError("The scene has no active camera: add a camera and make it the scene camera")
    return camera_dict(scene, scene.camera.evaluated_get(depsgraph))


def camera_dict(scene, camera):
    """The renderer's camera dict: Blender's camera model (sensor fit, shift, ortho, resolution)."""
    if camera.type != 'CAMERA':
        raise ExportError(f"The scene camera '{camera.name}' is not a camera object")
    data, render = camera.data, scene.render
    if data.type not in ("PERSP", "ORTHO"):
        raise ExportError(f"raylab renders perspective and orthographic cameras, not {data.type}")
    return dict(
        type=data.type,
        # Blender renders through the camera's rotation and location only: its scale is ignored.
        matrix_world=np.array(camera.matrix_world.normalized(), np.float64),
        lens=data.lens, sensor_width=data.sensor_width, sensor_height=data.sensor_height,
        sensor_fit=data.sensor_fit, shift_x=data.shift_x, shift_y=data.shift_y,
        ortho_scale=data.ortho_scale, clip_start=data.clip_start, clip_end=data.clip_end,
        resolution_x=render.resolution_x, resolution_y=render.resolution_y,
        resolution_percentage=render.resolution_percentage,
        pixel_aspect_x=render.pixel_aspect_x, pixel_aspect_y=render.pixel_aspect_y)


def _mesh_arrays(mesh, object_name):
    """(V, T) of an evaluated mesh, triangulated by Blender's loop triangles; None when it has no faces."""
    triangles = mesh_triangles(mesh)
    if len(triangles) == 0:
        return None
    vertices = mesh_vertices(mesh)
    if not np.isfinite(vertices).all():
        bad = int(np.flatnonzero(~np.isfinite(vertices).all(axis=1))[0])
        raise ExportError(f"Object '{object_name}': vertex {bad} of mesh '{mesh.name}' has a NaN or "
                          f"infinite coordinate; fix or delete it")
    return vertices, triangles


def _material_slot(obj, material_index, materials):
    """Index of the object's (first) material, exported once; the object colour when it has none."""
    material = next((slot.material for slot in obj.material_slots if slot.material is not None), None)
    if material is not None:
        key = ("material", material.original.name)
        if key not in material_index:
            material_index[key] = len(materials)
            materials.append(export_material(material))
    else:
        colour = tuple(round(c, 6) for c in obj.color[:3])
        key = ("object colour", colour)
        if key not in material_index:
            material_index[key] = len(materials)
            materials.append(_phong_material(colour, metallic=0.0, roughness=0.5, specular=0.5))
    return material_index[key]


def export_material(material):
    """Renderer material from the Principled BSDF feeding the material output (else the viewport colours)."""
    principled = _principled_bsdf(material)
    if principled is None:
        return _phong_material(material.diffuse_color[:3], metallic=material.metallic,
                               roughness=material.roughness, specular=material.specular_intensity)
    inputs = principled.inputs
    return _phong_material(inputs["Base Color"].default_value[:3], metallic=inputs["Metallic"].default_value,
                           roughness=inputs["Roughness"].default_value,
                           specular=compat.principled_value(principled, "specular"),
                           transmission=compat.principled_value(principled, "transmission"),
                           ior=inputs["IOR"].default_value)


def _principled_bsdf(material):
    tree = compat.node_tree(material)
    if tree is None:
        return None
    nodes = tree.nodes
    for output in nodes:
        if output.type == 'OUTPUT_MATERIAL' and output.is_active_output and output.inputs["Surface"].links:
            linked = output.inputs["Surface"].links[0].from_node
            if linked.type == 'BSDF_PRINCIPLED':
                return linked
    return next((node for node in nodes if node.type == 'BSDF_PRINCIPLED'), None)


def shininess_from_roughness(roughness):
    alpha = max(roughness, 1e-3) ** 2
    return min(max(2.0 / alpha ** 2 - 2.0, SHININESS_RANGE[0]), SHININESS_RANGE[1])


def _phong_material(colour, metallic, roughness, specular, transmission=0.0, ior=1.45):
    return dict(diffuse=tuple(float(c) for c in colour), specular=float(specular),
                # The renderer makes a metallic surface a mirror tinted by its colour (Whitted rays
                # cannot blur a rough one); a dielectric reflects only through Fresnel when it transmits.
                shininess=shininess_from_roughness(roughness), metallic=float(metallic), reflectivity=0.0,
                transmission=float(transmission), ior=float(ior),
                # The world colour is the ambient light and, as in Blender, lights a surface fully.
                ambient=1.0)


def _light(light, matrix_world):
    exported = dict(type=light.type, color=tuple(light.color), energy=compat.light_power(light),
                    matrix_world=np.array(matrix_world, np.float64),
                    radius=float(getattr(light, "shadow_soft_size", 0.0)), shadows=bool(light.use_shadow))
    if light.type == 'SPOT':
        exported.update(spot_size=float(light.spot_size), spot_blend=float(light.spot_blend))
    elif light.type == 'AREA':
        # The renderer samples square area lights: other shapes become the square of the same area.
        square = light.shape in ('SQUARE', 'DISK')
        exported.update(size=float(light.size if square else math.sqrt(light.size * light.size_y)), samples=3)
    return exported


def world_colour(world):
    """The world's background colour times strength (Background node, else the world colour)."""
    if world is None:
        return (0.0, 0.0, 0.0)
    tree = compat.node_tree(world)
    if tree is not None:
        for node in tree.nodes:
            if node.type == 'BACKGROUND':
                strength = node.inputs["Strength"].default_value
                return tuple(float(c) * strength for c in node.inputs["Color"].default_value[:3])
    return tuple(float(c) for c in world.color)


def build_scene(exported, **build):
    """A committed raylab.Scene of the export, and {raylab instance id: object name}; `build`: raylab.Scene's
    build settings (build_settings.build_kwargs), the core's defaults for those left out."""
    scene = api.Scene(**build)
    mesh_ids = [scene.add_mesh(vertices, triangles, normals=normals)
                for (vertices, triangles), normals in zip(exported.meshes, exported.normals)]
    objects = {}
    for instance in exported.instances:
        instance_id = scene.add_instance(mesh_ids[instance.mesh], instance.matrix, material=instance.material)
        objects[instance_id] = instance.object_name
    scene.commit()
    return scene, objects


def render_settings(exported, props, super_sampling=None, cost_rays=api.COST_RAYS[0]):
    """The renderer's settings from scene.raylab_render; the world colour is background and ambient;
    cost_rays (api.COST_RAYS) says which rays the cost passes count."""
    return dict(super_sampling=super_sampling or props.super_sampling, max_recursion=props.max_recursion,
                shadows=props.shadows, background=exported.background, ambient=exported.background,
                robust_offset=props.robust_offset, shadow_terminator=props.shadow_terminator,
                tile_size=props.tile_size, threads=0, cost_rays=cost_rays)
