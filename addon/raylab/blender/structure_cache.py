"""One raylab structure per mesh object, built from the evaluated mesh (modifiers applied).

Octree and BVH are built in OBJECT space and kept while only the object's transform changes: the
overlay and the probe carry them to the world with matrix_world. The exception is 'aabb', which is
re-computed in WORLD space from the transformed vertices, as VRT does, so that the drawn box is the
world AABB and the probe tests that same box. A structure is rebuilt only when the key changes:
(hash of the evaluated mesh, structure, max_depth, leaf_size) and, for 'aabb', the world matrix.
The mesh is re-read and re-hashed only after the depsgraph reported a geometry change.
"""
import hashlib

import bpy
import numpy as np

from .. import api

from . import properties
from .mesh_data import mesh_triangles, mesh_vertices

stats = {"structure_builds": 0, "mesh_reads": 0}

_meshes = {}   # object name -> _Mesh
_dirty = set()  # object names whose evaluated geometry changed since it was read
_entries = {}  # object name -> Entry


class _Mesh:
    __slots__ = ("vertices", "triangles", "digest")

    def __init__(self, vertices, triangles):
        self.vertices = vertices
        self.triangles = triangles
        self.digest = hashlib.blake2b(vertices.tobytes() + triangles.tobytes(), digest_size=16).digest()


class Entry:
    """A built structure (or why it could not be built) and the space its boxes live in."""

    __slots__ = ("key", "structure", "space", "error", "vertices", "_boxes")

    def __init__(self, key, structure, space, error, vertices):
        self.key = key
        self.structure = structure  # raylab.Structure, or None when `error` says why not
        self.space = space          # 'OBJECT': carry with matrix_world; 'WORLD': already in world space
        self.error = error
        self.vertices = vertices    # the object-space vertices the structure was built from
        self._boxes = None

    def boxes(self):
        if self._boxes is None:
            self._boxes = self.structure.boxes()
        return self._boxes

    def model_matrix(self, obj):
        """The matrix that carries this structure's boxes and rays' results to the world."""
        return np.identity(4) if self.space == 'WORLD' else matrix_of(obj)


def matrix_of(obj):
    return np.array(obj.matrix_world, dtype=np.float64)


def transform_points(matrix, points):
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def view_layer_of(scene):
    context = bpy.context
    return context.view_layer if getattr(context, "scene", None) == scene else scene.view_layers[0]


def target_objects(scene, view_layer=None):
    """The mesh objects the overlay draws and the probe tests (scene.raylab.objects)."""
    view_layer = view_layer or view_layer_of(scene)
    objects = [o for o in scene.objects if o.type == 'MESH' and o.visible_get(view_layer=view_layer)]
    if scene.raylab.objects == 'SELECTED':
        objects = [o for o in objects if o.select_get(view_layer=view_layer)]
    return objects


def read_mesh(obj, depsgraph):
    """The evaluated mesh of `obj` in object space: ((V,3) float32, (T,3) uint32)."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        vertices, triangles = mesh_vertices(mesh), mesh_triangles(mesh)
    finally:
        evaluated.to_mesh_clear()
    stats["mesh_reads"] += 1
    return vertices, triangles


def _mesh_of(obj, depsgraph):
    name = obj.name_full
    mesh = _meshes.get(name)
    if mesh is None or name in _dirty:
        mesh = _Mesh(*read_mesh(obj, depsgraph or bpy.context.evaluated_depsgraph_get()))
        _meshes[name] = mesh
        _dirty.discard(name)
    return mesh


def settings_key(settings):
    """The build settings that matter for the chosen structure (a change to another one costs no rebuild)."""
    structure = settings.structure
    return (structure,
            settings.max_depth if properties.uses(structure, "max_depth") else None,
            settings.leaf_size if properties.uses(structure, "leaf_size") else None)


def structure_for(obj, settings, depsgraph=None):
    """The cached Entry of `obj` for the scene's raylab settings, built if the key changed."""
    mesh = _mesh_of(obj, depsgraph)
    skey = settings_key(settings)
    world = skey[0] == "aabb"
    matrix = matrix_of(obj) if world else None
    key = (mesh.digest, skey, matrix.tobytes() if world else None)
    entry = _entries.get(obj.name_full)
    if entry is not None and entry.key == key:
        return entry
    structure, error = None, None
    if len(mesh.triangles) == 0:
        error = "the mesh has no faces"
    else:
        vertices = transform_points(matrix, mesh.vertices).astype(np.float32) if world else mesh.vertices
        try:
            structure = api.build(vertices, mesh.triangles, structure=skey[0],
                                     max_depth=settings.max_depth, leaf_size=settings.leaf_size)
            stats["structure_builds"] += 1
        except (ValueError, RuntimeError) as e:  # e.g. BuildError over the memory budget
            error = f"{skey[0]} not built: {e}"
    entry = Entry(key, structure, 'WORLD' if world else 'OBJECT', error, mesh.vertices)
    _entries[obj.name_full] = entry
    return entry


def cached(obj):
    """The Entry last built for `obj`, without building: None if there is none."""
    return _entries.get(obj.name_full)


def mark_geometry_changed(depsgraph):
    """Marks the objects whose evaluated geometry changed (not those that only moved)."""
    for update in depsgraph.updates:
        if not update.is_updated_geometry:
            continue
        changed = update.id.original
        if isinstance(changed, bpy.types.Object):
            _dirty.add(changed.name_full)
        elif isinstance(changed, bpy.types.Mesh):
            _dirty.update(o.name_full for o in bpy.data.objects if o.data == changed)


def clear():
    _meshes.clear()
    _dirty.clear()
    _entries.clear()


@bpy.app.handlers.persistent
def _on_depsgraph_update(scene, depsgraph):
    mark_geometry_changed(depsgraph)


@bpy.app.handlers.persistent
def _on_load(_):
    clear()


def register():
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph_update)
    bpy.app.handlers.load_post.append(_on_load)


def unregister():
    bpy.app.handlers.depsgraph_update_post.remove(_on_depsgraph_update)
    bpy.app.handlers.load_post.remove(_on_load)
    clear()
