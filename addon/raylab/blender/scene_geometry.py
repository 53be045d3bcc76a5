"""The evaluated scene's geometry as raylab models it, read ONE way for the viewport (structure_cache: the
boxes, the probe, "Costliest objects") and for F12 (scene_export): every mesh instance of the evaluated
depsgraph. Blender hands text, curves, surfaces and metaballs there as meshes of their evaluated geometry
(an instance whose parent is the object itself), collection and particle instances as instances of the
instanced object's mesh, and geometry nodes' instances as instances of the meshes the nodes made; each
instance shares its mesh (and so its structure) with the others of that mesh."""
from dataclasses import dataclass

import numpy as np


@dataclass
class MeshInstance:
    source: str        # names the geometry: the object's name, or "object / mesh" for a mesh its modifiers made
    owner: object      # the original object the user sees, selects and hides (a collection instance's empty)
    obj: object        # the evaluated object whose data is the mesh: valid until the iteration moves on
    mesh: object       # its evaluated bpy Mesh: valid until the iteration moves on
    matrix: np.ndarray  # (4,4) float64 object -> world


def mesh_instances(depsgraph):
    """Yields a MeshInstance for every shown mesh instance of the evaluated `depsgraph`, in its order; read
    `obj` and `mesh` before the next one is asked for (Blender frees an instance's object as it moves on)."""
    sources = {}  # source -> the evaluated mesh's pointer, so two meshes never share a name
    for instance in depsgraph.object_instances:
        obj = instance.object
        if obj.type != 'MESH' or obj.data is None:
            continue  # a text, curve or metaball object comes again as the mesh instance of its geometry
        if not instance.is_instance and not instance.show_self:
            continue
        parent = instance.parent if instance.is_instance else None
        owner = parent.original if parent is not None else obj.original
        source = source_name(obj)
        pointer = obj.data.as_pointer()
        if sources.setdefault(source, pointer) != pointer:
            source = f"{source} / {obj.data.name}"
            while sources.setdefault(source, pointer) != pointer:
                source += "'"
        yield MeshInstance(source, owner, obj, obj.data, np.array(instance.matrix_world, np.float64))


def source_name(obj):
    """The name of an evaluated mesh object's geometry: its original object's name when the mesh is that
    object's own (a mesh object, a text's or curve's evaluated geometry), else "object / mesh" (a mesh that
    geometry nodes made and instanced)."""
    original = obj.original
    # By name: an instance's mesh is Blender's copy of the datablock, a different ID from the original's.
    own = original.data is not None and (original.type != 'MESH' or obj.data.name == original.data.name)
    return original.name_full if own else f"{original.name_full} / {obj.data.name}"
