"""Blender meshes as numpy arrays and back: vertices and Blender's triangulation read with foreach_get,
a mesh built from arrays with foreach_set, the corner normals as Blender shades them (through compat),
and a fingerprint that names a mesh object's geometry. No Python loop over vertices anywhere."""
import math
import zlib

import bpy
import numpy as np

from . import compat

# Faces meeting at a sharper angle keep their edge under smooth shading (Blender's auto smooth).
SMOOTH_ANGLE = math.radians(60.0)


def mesh_vertices(mesh):
    """The vertex coordinates of a bpy mesh as a (V,3) float32 array (foreach_get, no Python loop)."""
    vertices = np.empty(3 * len(mesh.vertices), np.float32)
    mesh.vertices.foreach_get("co", vertices)
    return vertices.reshape(-1, 3)


def mesh_triangles(mesh):
    """Blender's triangulation of a bpy mesh (its loop triangles) as a (T,3) uint32 array."""
    mesh.calc_loop_triangles()
    triangles = np.empty(3 * len(mesh.loop_triangles), np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    return triangles.reshape(-1, 3).astype(np.uint32)


def mesh_from_arrays(name, vertices, triangles, smooth=False):
    """A new bpy mesh of (V,3) vertices and (T,3) triangles, filled with foreach_set (no Python loop).

    smooth: Shade Smooth with auto smooth at SMOOTH_ANGLE, as a curved scanned mesh is meant to look.
    """
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(vertices))
    mesh.vertices.foreach_set("co", np.ascontiguousarray(vertices, np.float32).ravel())
    mesh.loops.add(3 * len(triangles))
    mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(triangles, np.int32).ravel())
    mesh.polygons.add(len(triangles))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(triangles), 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(len(triangles), 3, np.int32))
    mesh.update(calc_edges=True)
    mesh.validate()
    if smooth:
        mesh.polygons.foreach_set("use_smooth", np.ones(len(triangles), bool))
        compat.smooth_by_angle(mesh, SMOOTH_ANGLE)
        mesh.update()
    return mesh


def principled_material(name, colour, roughness=0.5, metallic=0.0):
    material = bpy.data.materials.new(name)
    bsdf = compat.use_node_tree(material).nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Metallic"].default_value = metallic
    material.diffuse_color = (*colour, 1.0)
    return material


def corner_normals(mesh):
    """(T,3,3) normals of the loop triangles' corners as Blender shades them: Shade Smooth, Flat (the
    face normal at each corner) and auto smooth's sharp edges. Needs calc_loop_triangles() first."""
    corners = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("loops", corners)
    normals = compat.corner_normals(mesh)[corners]
    # A degenerate face can give a non-finite normal: zero makes the renderer shade it flat.
    return np.nan_to_num(normals, nan=0.0, posinf=0.0, neginf=0.0).reshape(-1, 3, 3)


def mesh_fingerprint(obj):
    """Names the geometry of a mesh object: its data block, vertex count and a CRC of the coordinates,
    so that results computed on it (the leak test) can tell when the mesh was swapped or edited."""
    vertices = mesh_vertices(obj.data)
    return f"{obj.data.name}:{len(vertices)}:{zlib.crc32(vertices.tobytes())}"
