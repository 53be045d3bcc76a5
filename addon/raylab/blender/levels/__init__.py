"""Tutorial levels: each is data in levels/<id>/ (level.toml, text.md, diagrams/*.png).

    reading    the level format: level.toml, its declarative task conditions, text.md (no bpy)
    state      the level's state stored on its scene (no bpy)
    meshes     the shipped meshes and the user's mesh objects a level's mesh can be swapped for
    scene      building a level's scene from scratch, next / previous, the mesh swap
    tasks      the condition engine: tasks tick themselves (a depsgraph handler and a timer)
    operators  Open Level, Next Level, Previous Level, Swap Mesh

The names other modules and the tests use are re-exported here. Outside Blender (no bpy) only reading
and state load, so the level format can be checked in plain Python.
"""
import sys

from .reading import (COMPARISONS, ID_PROPERTY_TESTS, LEVEL_ROOTS, OBJECT_TESTS, PACKAGE_DIR,  # noqa: F401
                      PROBE_TESTS, SETTING_GROUPS, Level, LevelError, Task, available_levels, find_level, levels_root,
                      load_level, plain, read_text, validate_condition)
from .state import MESH_OBJECT_NAME, OWNER_KEY, STATE_KEY, level_mesh_object, owned, state  # noqa: F401

if "bpy" in sys.modules:
    from . import operators, tasks
    from .meshes import (GEOMETRY_TYPES, MESH_DIR, Z_UP_MESHES, mesh_credit, mesh_sources, normalised,  # noqa: F401
                         object_mesh_arrays, shipped_mesh_arrays, shipped_meshes)
    from .operators import (RAYLAB_MT_level_swap_mesh, RAYLAB_OT_level_next, RAYLAB_OT_level_open,  # noqa: F401
                            RAYLAB_OT_level_previous, RAYLAB_OT_level_swap_mesh)
    from .scene import KEPT_SUFFIX, LEAVING, MESH_SIZE, _remove_scene, open_level, step_level, swap_mesh  # noqa: F401
    from .tasks import CHECK_INTERVAL, _check_timer, check_tasks, evaluate_condition, task_list  # noqa: F401


def register():
    operators.register()
    tasks.register()


def unregister():
    tasks.unregister()
    operators.unregister()
