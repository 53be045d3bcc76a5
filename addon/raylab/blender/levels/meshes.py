"""The meshes a level can show: the shipped meshes (meshes/*.obj, with their credit lines from
meshes/CREDITS.md) and the user's own mesh objects, as the sources the mesh swap offers and as arrays
normalised to the level's size."""
import os

import bpy
import numpy as np

from ... import api
from ..mesh_data import mesh_triangles, mesh_vertices
from .reading import PACKAGE_DIR, LevelError
from .state import level_mesh_object

MESH_DIR = os.path.join(PACKAGE_DIR, "meshes")
Z_UP_MESHES = {"plane_holes.obj"}  # stands on z = 0 in its file


def shipped_meshes():
    return sorted(n for n in os.listdir(MESH_DIR) if n.endswith(".obj"))


def mesh_credit(filename):
    """The credit line of a shipped mesh, from meshes/CREDITS.md (licence and source)."""
    with open(os.path.join(MESH_DIR, "CREDITS.md"), encoding="utf-8") as f:
        for line in f:
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(cells) >= 5 and cells[0] == filename:
                return f"{filename}: {cells[4]}; from {cells[3]}"
    return f"{filename}: see meshes/CREDITS.md"


def normalised(vertices, size):
    """Centres the mesh's box on the origin and scales its largest side to `size`."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    extent = float((hi - lo).max())
    if not extent > 0.0:
        raise LevelError("the mesh is flat or empty: it has no extent")
    return ((vertices - (lo + hi) / 2) * (size / extent)).astype(np.float32)


def shipped_mesh_arrays(filename):
    path = os.path.join(MESH_DIR, filename)
    if not os.path.isfile(path):
        raise LevelError(f"no shipped mesh {filename!r} (shipped: {', '.join(shipped_meshes())})")
    vertices, triangles = api.load_mesh(path)
    if filename in Z_UP_MESHES:
        return vertices, triangles
    # The other OBJ files are Y-up; Blender is Z-up.
    return np.c_[vertices[:, 0], -vertices[:, 2], vertices[:, 1]], triangles


def object_mesh_arrays(obj):
    """The triangles of a user's mesh object in its own space, as it renders: modifiers applied, transform
    left out. An object of another scene (the student's, while the level's is shown) is linked into the
    shown scene for the moment it is evaluated: Blender 4.x does not evaluate the depsgraph of a scene no
    window shows. An object in no scene has nothing to evaluate it: its mesh is taken as it is."""
    context = bpy.context
    shown = context.view_layer.objects.get(obj.name) == obj
    borrowed = not shown and bool(obj.users_scene)
    if borrowed:
        context.scene.collection.objects.link(obj)
    try:
        evaluated = obj
        if shown or borrowed:
            depsgraph = context.evaluated_depsgraph_get()
            depsgraph.update()
            evaluated = obj.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        try:
            triangles = mesh_triangles(mesh)
            if len(triangles) == 0:
                raise LevelError(f"{obj.name} has no faces")
            return mesh_vertices(mesh), triangles
        finally:
            evaluated.to_mesh_clear()
    finally:
        if borrowed:
            context.scene.collection.objects.unlink(obj)


# Objects whose evaluated geometry is a mesh (to_mesh): meshes, curves, surfaces, texts, metaballs.
GEOMETRY_TYPES = ('MESH', 'CURVE', 'SURFACE', 'FONT', 'META')


def mesh_sources(scene):
    """Everything the level's mesh can be swapped for: ("file:NAME", ...) and ("object:NAME", ...)."""
    level_obj = level_mesh_object(scene)
    items = [f"file:{name}" for name in shipped_meshes()]
    items += [f"object:{o.name}" for o in bpy.data.objects if o.type in GEOMETRY_TYPES and o != level_obj
              and o.get("raylab_mesh_source") is None]
    return items
