"""The leak test's escaped rays in the 3D viewport. After Count Leaking Rays (the where-methods-fail
level), the rays that Möller–Trumbore let out of the closed level mesh are drawn in red, from the
centre of the mesh's box out through the vertex or edge where they slipped between two triangles
(a yellow dot), and on beyond the surface. Drawn through the mesh: the rays start inside it."""
import bpy
import numpy as np

from . import draw, levels

RAY_COLOR = (1.0, 0.15, 0.1, 0.9)
CROSSING_COLOR = (1.0, 0.85, 0.1, 1.0)
OVERSHOOT = 1.6  # each ray is drawn to 1.6 times its distance from the centre to the surface

_handles = []


def leak_segments(scene):
    """World-space starts, ends and surface crossings (each (N,3)) of the escaped rays to draw, or None:
    no leak test in this scene, or the level mesh changed since."""
    leaks = scene.get(levels.LEAK_KEY)
    obj = levels.level_mesh_object(scene)
    if leaks is None or obj is None or not leaks.get("escaped") or leaks.get("mesh") != levels.mesh_fingerprint(obj):
        return None
    matrix = np.array(obj.matrix_world)
    centre = np.asarray(leaks["centre"], dtype=float)
    crossings = np.asarray(leaks["escaped"], dtype=float).reshape(-1, 3)
    ends = centre + OVERSHOOT * (crossings - centre)
    starts = np.repeat(centre[None], len(crossings), axis=0)
    return tuple(p @ matrix[:3, :3].T + matrix[:3, 3] for p in (starts, ends, crossings))


def _draw():
    segments = leak_segments(bpy.context.scene)
    if segments is None:
        return
    starts, ends, crossings = segments
    draw.draw_segments(starts, ends, np.tile(np.array(RAY_COLOR, np.float32), (len(starts), 1)), True, 2.0)
    draw.draw_points(crossings, CROSSING_COLOR, True, 6.0)


def register():
    _handles.append(bpy.types.SpaceView3D.draw_handler_add(_draw, (), 'WINDOW', 'POST_VIEW'))


def unregister():
    for handle in _handles:
        bpy.types.SpaceView3D.draw_handler_remove(handle, 'WINDOW')
    _handles.clear()
