"""The raylab.Scene of each Blender scene: its shown geometry, what the overlay draws and the probe
and its fan trace, with the renderer's geometry model: the evaluated depsgraph's mesh instances read as F12
reads them (scene_geometry.mesh_instances: mesh objects, text, curves, surfaces, metaballs, collection
and particle instances, geometry nodes' instances), one raylab mesh per geometry shared by its instances,
each instance with its matrix, a top level over the instances where the structure has one.

The scene is kept between redraws and changed only where Blender changed: a new transform moves an
instance (no rebuild; the top level is refitted), a geometry change replaces that object's mesh (its
structure alone is rebuilt), other build settings start a new scene. A deforming mesh (armature, Wave
modifier, shape keys: the same triangles, moved vertices) has its structure refitted instead when
scene.raylab.animation_update is 'REFIT' (raylab.Scene.refit_mesh). The mesh is re-read and re-hashed
only after the depsgraph reported a geometry change, or on a frame change for objects whose geometry may
be animated (frame_change_post: playback reports no depsgraph update). One exception to the object-space
model: 'aabb' is VRT's box, axis-aligned in the WORLD, so its mesh is the object's world-space vertices
under an identity instance and is replaced when the object moves; the drawn box is then the world AABB and
the probe tests that box.
"""
import hashlib
import itertools
import re

import bpy
import numpy as np

from .. import api

from . import build_settings, scene_geometry
from .mesh_data import mesh_triangles, mesh_vertices

WORLD_ALIGNED = "aabb"  # the one structure kept in world space (see above)

stats = {"structure_builds": 0, "structure_refits": 0, "mesh_reads": 0}

_meshes = {}   # geometry name (MeshInstance.source) -> (its object's identity, _Mesh)
_dirty = set()  # object names whose evaluated geometry changed since it was read
_models = {}   # Blender scene name -> SceneModel
# Every commit of every model takes the next number: a cache keyed on a model's version cannot mistake a
# new model for an old one (id() of a freed model is reused by the next one Python allocates).
_versions = itertools.count(1)


class _Mesh:
    __slots__ = ("vertices", "triangles", "digest", "topology")

    def __init__(self, vertices, triangles):
        self.vertices = vertices
        self.triangles = triangles
        self.digest = hashlib.blake2b(vertices.tobytes() + triangles.tobytes(), digest_size=16).digest()
        # What a refit keeps: the triangles and the vertex count.
        self.topology = hashlib.blake2b(triangles.tobytes() + len(vertices).to_bytes(8, "little"),
                                        digest_size=16).digest()


class Entry:
    """One object's structure in the scene model (or why it has none) and the space its boxes live in.
    What the panels show of its boxes (box_count, depths, leaf_depths) is counted when it is made, as
    panels' draws must not call the core or numpy on its arrays (either lets go of Python's interpreter
    lock: levels.available_levels says why that matters)."""

    __slots__ = ("key", "structure", "space", "error", "_boxes", "box_count", "depths", "leaf_depths")

    def __init__(self, key, structure, space, error, counted=None):
        self.key = key              # changes whenever the structure does
        self.structure = structure  # raylab.Structure, or None when `error` says why not
        self.space = space          # 'OBJECT': carry with matrix_world; 'WORLD': already in world space
        self.error = error
        self._boxes = None
        self.box_count, self.depths, self.leaf_depths = 0, frozenset(), frozenset()
        if structure is not None:
            if counted is None:  # `counted`: the same structure's counts, from the entry before a commit
                boxes = self.boxes()
                counted = (len(boxes["depth"]), frozenset(np.unique(boxes["depth"]).tolist()),
                           frozenset(np.unique(boxes["depth"][boxes["leaf"]]).tolist()))
            self.box_count, self.depths, self.leaf_depths = counted

    def counted(self):
        return self.box_count, self.depths, self.leaf_depths

    def boxes(self):
        if self._boxes is None:
            self._boxes = self.structure.boxes()
        return self._boxes

    def model_matrix(self, obj):
        """The matrix that carries this structure's boxes and rays' results to the world."""
        return np.identity(4) if self.space == 'WORLD' else matrix_of(obj)


class _Part:
    """An object's mesh in the raylab.Scene: its mesh id, the key it was added with, why it is not
    traced (its mesh, or its instance's matrix), its entry."""

    __slots__ = ("mesh", "key", "triangle_count", "topology", "error", "instance_error", "entry", "counted")

    def __init__(self, mesh, key, triangle_count, topology=None, error=None):
        self.mesh = mesh
        self.key = key
        self.triangle_count = triangle_count
        self.topology = topology    # _Mesh.topology of the mesh in the scene (None: none there)
        self.error = error          # the mesh cannot be added (no faces, a NaN vertex)
        self.instance_error = None  # the scene refused its matrix (e.g. scaled to zero)
        self.entry = None
        self.counted = None         # (key, Entry.counted()) of the last entry with a structure


class SceneModel:
    """One Blender scene's raylab.Scene and which geometry is which instance. Parts and entries are
    named by their geometry (MeshInstance.source: a mesh object's or text's own name); in the world-aligned
    'aabb' each instance has its own part, the second and later ones of a geometry named "name #k"."""

    def __init__(self, settings_key, settings):
        structure = settings_key[0]
        self.settings_key = settings_key
        # The panels' names of the settings a core message may name (its error says "max_depth").
        self.labels = {name: settings.bl_rna.properties[name].name for name in build_settings.SETTINGS
                       if name in settings.bl_rna.properties}
        self.scene = api.Scene(**build_settings.build_kwargs(settings))
        self.world = structure == WORLD_ALIGNED
        self.parts = {}       # geometry name -> _Part
        self.shown = ([], [])  # the geometry names and matrix bytes last asked for
        self.targets = []      # the geometries last asked to be traced, those that cannot be too
        self.owners = {}       # geometry name -> the name of the object the user sees it as
        self.instances = []   # instance id -> geometry name
        self.matrices = []    # instance id -> its (4,4) matrix (identity where the mesh is in world space)
        self.stale = 0        # meshes added or replaced since the last commit
        self.refits = 0       # meshes refitted since the last commit
        self.error = None     # why the last commit failed
        self.committed = False
        self.version = next(_versions)  # what the probe's and cost map's caches key on

    def triangle_count(self):
        return sum(self.parts[name].triangle_count for name in self.instances)

    def errors(self):
        """Why objects asked for are not traced (a NaN vertex, no faces, a singular matrix), and why the last
        commit failed."""
        asked = [(name, self.parts[name]) for name in self.targets if name in self.parts]
        return [f"{name}: {part.error or part.instance_error}" for name, part in asked
                if part.error or part.instance_error] + ([self.error] if self.error else [])

    def entry(self, name, make=True):
        """The object's Entry, made now if there is none yet and `make` (None then otherwise)."""
        part = self.parts.get(name)
        if part is None:
            return None
        if part.entry is None and make:
            error = part.error or part.instance_error or self.error or (None if self.committed else "not built yet")
            structure = None if error else self.scene.structure(part.mesh)
            counted = part.counted[1] if part.counted is not None and part.counted[0] == part.key else None
            part.entry = Entry(part.key, structure, 'WORLD' if self.world else 'OBJECT', error, counted)
            if structure is not None:
                part.counted = (part.key, part.entry.counted())
        return part.entry

    def drawn(self):
        """[(geometry name, (4,4) matrix)] of every traced instance: what the overlay draws where."""
        return list(zip(self.instances, self.matrices))

    def shown_entries(self):
        """{geometry name: Entry or None} of the geometries last asked for, without making any entry (what a
        panel's draw may ask)."""
        return {name: self.entry(name, make=False) for name in dict.fromkeys(self.targets) if name in self.parts}

    def _update_part(self, name, mesh, matrix, refit):
        """Adds, replaces or (`refit`, the same triangles moved) refits the geometry's mesh if it changed;
        True if it did."""
        key = (mesh.digest, self.settings_key, matrix.tobytes() if self.world else None)
        part = self.parts.get(name)
        if part is not None and part.key == key:
            return False
        # Only kinds that keep a topology refit (the core would rebuild the others: count them as builds).
        refit = (refit and api.STRUCTURE_INFO[self.settings_key[0]]["refits"] and part is not None
                 and part.error is None and part.topology == mesh.topology)
        new = self._new_part(part.mesh if part else None, mesh, matrix, key, refit)
        if part is not None:  # a refused instance stays refused until its matrix changes
            new.instance_error = part.instance_error
        self.parts[name] = new
        return True

    def _new_part(self, mesh_id, mesh, matrix, key, refit=False):
        """The object's mesh added to the scene (or replacing or refitting mesh `mesh_id`), or why it
        cannot be."""
        if len(mesh.triangles) == 0:
            return _Part(mesh_id, key, 0, error="the mesh has no faces")
        vertices = transform_points(matrix, mesh.vertices).astype(np.float32) if self.world else mesh.vertices
        try:
            if mesh_id is None:
                mesh_id = self.scene.add_mesh(vertices, mesh.triangles)
            elif refit:
                self.scene.refit_mesh(mesh_id, vertices)
            else:
                self.scene.replace_mesh(mesh_id, vertices, mesh.triangles)
        except ValueError as error:  # e.g. a NaN vertex
            return _Part(mesh_id, key, 0, error=str(error))
        if refit:
            self.refits += 1
        else:
            self.stale += 1
        return _Part(mesh_id, key, len(mesh.triangles), mesh.topology)

    def _set_instances(self, names, matrices):
        """Instances for the objects `names` with (4,4) `matrices`: moved where only matrices changed,
        else set again; nothing when they are what was asked for last. True if anything changed."""
        request = (names, [m.tobytes() for m in matrices])
        if request == self.shown:
            return False
        if names == self.instances:
            moved = [i for i, m in enumerate(request[1]) if m != self.shown[1][i]]
            try:
                for i in moved:
                    self.scene.set_transform(i, matrices[i])
                self.shown = request
                return True
            except ValueError:
                pass  # a matrix the scene refuses: set the instances again below, without it
        self.shown = request
        self.scene.clear_instances()
        self.instances, self.matrices = [], []
        for name, matrix in zip(names, matrices):
            part = self.parts[name]
            part.instance_error = None
            try:
                self.scene.add_instance(part.mesh, matrix)
            except ValueError as error:  # singular: e.g. scaled to zero
                part.instance_error = f"not traced: {error}"
                continue
            self.instances.append(name)
            self.matrices.append(matrix)
        return True

    def update(self, depsgraph, shown, refit=True):
        """Brings the scene up to date with the depsgraph's mesh instances whose owner `shown(owner)`
        accepts; `refit`: a deformed mesh's structure is refitted (else rebuilt)."""
        changed = False
        names, matrices, targets, read, copies = [], [], [], {}, {}
        for instance in scene_geometry.mesh_instances(depsgraph):
            if not shown(instance.owner):
                continue
            name = instance.source
            if self.world:  # a world-space mesh per instance
                copies[name] = copies.get(name, 0) + 1
                name = name if copies[name] == 1 else f"{name} #{copies[name]}"
            targets.append(name)
            self.owners[name] = instance.owner.name_full
            matrix = instance.matrix
            changed |= self._update_part(name, _mesh_of(instance.source, instance, read), matrix, refit)
            if self.parts[name].error is None:
                names.append(name)
                matrices.append(np.identity(4) if self.world else matrix)
        _dirty.difference_update(read.values())
        self.targets = targets
        changed |= self._set_instances(names, matrices)
        if changed:
            self._commit()

    def _commit(self):
        self.version = next(_versions)
        for part in self.parts.values():
            part.entry = None
        try:
            self.scene.commit()
        except (ValueError, RuntimeError) as error:  # e.g. BuildError over the memory budget
            self.error = f"{self.settings_key[0]} not built: {readable(str(error), self.labels)}"
            self.committed = False
            return
        stats["structure_builds"] += self.stale
        stats["structure_refits"] += self.refits
        self.stale = self.refits = 0
        self.error = None
        self.committed = True
        for name in self.parts:  # made here, not when a panel's draw first asks (structure_cache.cached)
            self.entry(name)


def readable(message, labels):
    """A core message in the panels' words: byte counts in KiB, MiB or GiB ("4294967296 bytes" is 4 GiB),
    setting names as their labels (`labels`: {"max_depth": "Max depth"})."""
    message = re.sub(r"\b(\d+) bytes\b", lambda m: _size(int(m.group(1))), message)
    message = re.sub(r"\bbudget of (\d+)\b", lambda m: "budget of " + _size(int(m.group(1))), message)
    for name, label in labels.items():
        message = re.sub(rf"\b{name}\b", label, message)
    return message


def _size(count):
    for power, unit in ((3, "GiB"), (2, "MiB"), (1, "KiB")):
        if count >= 1024 ** power:
            return f"{count / 1024 ** power:.3g} {unit}"
    return f"{count:,} bytes"


def matrix_of(obj):
    return np.array(obj.matrix_world, dtype=np.float64)


def transform_points(matrix, points):
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def view_layer_of(scene):
    context = bpy.context
    return context.view_layer if getattr(context, "scene", None) == scene else scene.view_layers[0]


def target_objects(scene, view_layer=None):
    """The mesh objects shown (scene.raylab.objects), without the probe's ray object: the objects the spin
    turns and the probe aims at. The model itself reads every shown geometry (shown_filter)."""
    view_layer = view_layer or view_layer_of(scene)
    shown = shown_filter(scene, view_layer)
    return [o for o in scene.objects if o.type == 'MESH' and shown(o)]


def shown_filter(scene, view_layer=None):
    """Whether the overlay draws and the probe tests an object's geometry (an instance's: its owner's):
    shown in the view layer, selected if scene.raylab.objects says so, and not the probe's ray object (it
    is the ray, not something in its way)."""
    view_layer = view_layer or view_layer_of(scene)
    ray_object = scene.raylab.probe_object
    selected_only = scene.raylab.objects == 'SELECTED'

    def shown(obj):
        return (obj != ray_object and obj.visible_get(view_layer=view_layer)
                and (not selected_only or obj.select_get(view_layer=view_layer)))
    return shown


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


def identity(obj):
    """Which object and mesh a name stands for now: a new object under an old name (a level opened after
    another, whose mesh object has the same name; 5.2 reports no geometry change for it) is another mesh.
    session_uid where Blender has it (3.6+), the mesh's name always."""
    data = obj.data
    return (getattr(obj, "session_uid", None), getattr(data, "session_uid", None),
            data.name_full if data is not None else None)


def _mesh_of(name, instance, read):
    """The _Mesh of geometry `name` (a MeshInstance's source), read from its evaluated mesh if it is new,
    changed and not read yet by this update (`read`: geometry name -> object name, of those it read)."""
    obj = instance.obj.original
    known, mesh = _meshes.get(name, (None, None))
    now = identity(obj)
    if mesh is None or (obj.name_full in _dirty and name not in read) or known != now:
        mesh = _Mesh(mesh_vertices(instance.mesh), mesh_triangles(instance.mesh))
        stats["mesh_reads"] += 1
        _meshes[name] = (now, mesh)
        read[name] = obj.name_full
    return mesh


def scene_model(scene, depsgraph=None):
    """The SceneModel of a Blender scene, brought up to date with its shown geometry and settings."""
    settings = scene.raylab
    key = build_settings.cache_key(settings)
    model = _models.get(scene.name_full)
    if model is None or model.settings_key != key:  # new settings rebuild every structure anyway
        model = _models[scene.name_full] = SceneModel(key, settings)
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    shown = shown_filter(scene)
    model.update(depsgraph, shown, refit=settings.animation_update == 'REFIT')
    if len(model.parts) > 2 * len(model.targets) + 16:  # geometry long gone would keep its meshes
        model = _models[scene.name_full] = SceneModel(key, settings)
        model.update(depsgraph, shown, refit=False)
    return model


def structure_for(obj, settings, depsgraph=None):
    """The Entry of `obj` in its scene's model for the scene's raylab settings, built if anything changed."""
    model = scene_model(settings.id_data, depsgraph)
    entry = model.entry(obj.name_full)
    if entry is None:
        return Entry(None, None, 'OBJECT', f"'{obj.name}' is not shown (hidden, not a mesh, or not selected)")
    return entry


def cached(obj, scene=None):
    """The Entry last made for `obj`, without building or making one (what a panel's draw may ask): None
    if there is none."""
    scene = scene or bpy.context.scene
    model = _models.get(scene.name_full)
    return None if model is None else model.entry(obj.name_full, make=False)


def cached_entries(scene=None):
    """{geometry name: Entry or None} of the shown geometries last read, without building or making any
    (what a panel's draw may ask)."""
    scene = scene or bpy.context.scene
    model = _models.get(scene.name_full)
    return {} if model is None else model.shown_entries()


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


def may_deform(obj):
    """Whether the evaluated geometry of mesh object `obj` may change from frame to frame: modifiers
    (an Armature, a Wave), shape keys, an armature parent."""
    return obj.type == 'MESH' and (len(obj.modifiers) > 0 or obj.data.shape_keys is not None
                                   or obj.parent_type == 'ARMATURE')


def mark_frame_changed(scene, depsgraph):
    """On a frame change: every object whose geometry may be animated is re-read (an unchanged mesh
    hashes the same and changes nothing), as are those the depsgraph reports."""
    _dirty.update(o.name_full for o in scene.objects if may_deform(o))
    if depsgraph is not None:
        mark_geometry_changed(depsgraph)


def clear():
    _meshes.clear()
    _dirty.clear()
    _models.clear()


@bpy.app.handlers.persistent
def _on_depsgraph_update(scene, depsgraph):
    mark_geometry_changed(depsgraph)


@bpy.app.handlers.persistent
def _on_frame_change(scene, depsgraph=None):
    mark_frame_changed(scene, depsgraph)


@bpy.app.handlers.persistent
def _on_load(_):
    clear()


def register():
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph_update)
    bpy.app.handlers.frame_change_post.append(_on_frame_change)
    bpy.app.handlers.load_post.append(_on_load)


def unregister():
    bpy.app.handlers.depsgraph_update_post.remove(_on_depsgraph_update)
    bpy.app.handlers.frame_change_post.remove(_on_frame_change)
    bpy.app.handlers.load_post.remove(_on_load)
    clear()
