"""The structure overlay: every shown mesh object's boxes as wireframe, over the 3D viewport.

One GPU batch per object's structure (12 edges per box), cached and rebuilt only when the structure
or the filters change; the object's transform goes in as the model matrix, so moving an object
redraws the same batch. Dense octrees stay readable by fading deep boxes and boxes of structures
with many boxes, by the depth range and by showing the leaves alone.
"""
import math

import bpy
import numpy as np
from mathutils import Matrix

from . import structure_cache

stats = {"batch_builds": 0}

# One colour per depth, repeating past the end: warm to cold, distinct next to each other.
DEPTH_PALETTE = np.array([
    (1.00, 0.25, 0.20), (1.00, 0.60, 0.10), (0.95, 0.95, 0.15), (0.35, 1.00, 0.25), (0.15, 0.95, 0.85),
    (0.25, 0.55, 1.00), (0.60, 0.35, 1.00), (1.00, 0.35, 0.85), (1.00, 1.00, 1.00), (0.60, 0.60, 0.60),
    (0.80, 0.55, 0.35),
], dtype=np.float32)

# The 12 edges of a box over its 8 corners, corner c = (x bit 0, y bit 1, z bit 2) of lo/hi.
BOX_EDGES = np.array([(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7),
                      (0, 4), (1, 5), (2, 6), (3, 7)], dtype=np.uint32)
_CORNER_BITS = np.array([[(c >> axis) & 1 for axis in range(3)] for c in range(8)], dtype=bool)

SPIN_STEP = math.radians(2.0)  # per frame change or timer tick
SPIN_INTERVAL = 1.0 / 30.0


class LineGeometry:
    """Box wireframe arrays ready for a GPU batch; the batch itself is made lazily when drawing
    (the gpu module is unavailable in background mode)."""

    __slots__ = ("key", "positions", "colors", "indices", "box_count", "batch")

    def __init__(self, key, positions, colors, indices, box_count):
        self.key = key
        self.positions = positions
        self.colors = colors
        self.indices = indices
        self.box_count = box_count
        self.batch = None


_geometry = {}  # object name -> LineGeometry


def box_wireframe(lo, hi):
    """Corners (8B,3) float32 and edge indices (12B,2) uint32 of B boxes."""
    corners = np.where(_CORNER_BITS[None, :, :], hi[:, None, :], lo[:, None, :]).reshape(-1, 3)
    indices = (BOX_EDGES[None, :, :] + (8 * np.arange(len(lo), dtype=np.uint32))[:, None, None]).reshape(-1, 2)
    return np.ascontiguousarray(corners, dtype=np.float32), np.ascontiguousarray(indices, dtype=np.uint32)


def fade_alpha(depth, box_count):
    """Alpha of boxes: falls with depth and with the number of boxes drawn, never to nothing."""
    by_depth = 1.0 / (1.0 + 0.35 * depth.astype(np.float32))
    by_density = min(1.0, math.sqrt(200.0 / max(box_count, 1)))
    return np.maximum(by_depth * by_density, 0.12)


def filter_key(settings):
    return (settings.depth_min, settings.depth_max, settings.leaves_only, settings.color_by_depth,
            settings.fade, tuple(round(c, 4) for c in settings.line_color))


def selected_boxes(boxes, settings):
    """The mask of boxes the filters let through: the depth range, leaves only."""
    depth = boxes["depth"]
    keep = (depth >= settings.depth_min) & (depth <= settings.depth_max)
    if settings.leaves_only:
        keep &= boxes["leaf"]
    return keep


def box_colors(depth, settings):
    """(B,4) colours: the palette by depth or the line colour, with fading alpha."""
    if settings.color_by_depth:
        rgba = np.empty((len(depth), 4), dtype=np.float32)
        rgba[:, :3] = DEPTH_PALETTE[depth % len(DEPTH_PALETTE)]
        rgba[:, 3] = 1.0
    else:
        rgba = np.tile(np.asarray(settings.line_color, dtype=np.float32), (len(depth), 1))
    if settings.fade:
        rgba[:, 3] *= fade_alpha(depth, len(depth))
    return rgba


def line_geometry(obj, scene, depsgraph=None):
    """The cached wireframe of `obj`'s structure for the scene's settings, rebuilt only when the
    structure or the filters changed; None when the structure is unavailable."""
    settings = scene.raylab
    entry = structure_cache.structure_for(obj, settings, depsgraph)
    if entry.structure is None:
        _geometry.pop(obj.name_full, None)
        return None
    key = (entry.key, filter_key(settings))
    geometry = _geometry.get(obj.name_full)
    if geometry is not None and geometry.key == key:
        return geometry
    boxes = entry.boxes()
    keep = selected_boxes(boxes, settings)
    positions, indices = box_wireframe(boxes["lo"][keep], boxes["hi"][keep])
    colors = np.repeat(box_colors(boxes["depth"][keep], settings), 8, axis=0)
    geometry = LineGeometry(key, positions, colors, indices, int(keep.sum()))
    _geometry[obj.name_full] = geometry
    stats["batch_builds"] += 1
    return geometry


# --- drawing (GUI only) ---------------------------------------------------------------------------

THIN = 'SMOOTH_COLOR'            # 1-pixel lines and points: cheap even for 100k boxes
THICK = 'POLYLINE_SMOOTH_COLOR'  # wide lines (a geometry shader): for the few lines that stand out


def make_batch(primitive, positions, colors, indices=None, shader_name=THIN):
    import gpu
    from gpu_extras.batch import batch_for_shader
    return batch_for_shader(gpu.shader.from_builtin(shader_name), primitive, {"pos": positions, "color": colors},
                            indices=indices)


def draw_batch(batch, model_matrix, xray, shader_name=THIN, width=1.0, point_size=1.0):
    """Draws a batch made by make_batch with `model_matrix` (4,4) carrying it to the world."""
    import gpu
    shader = gpu.shader.from_builtin(shader_name)
    gpu.state.blend_set('ALPHA')
    gpu.state.depth_test_set('NONE' if xray else 'LESS_EQUAL')
    gpu.state.depth_mask_set(False)
    gpu.state.point_size_set(point_size)
    if shader_name == THICK:
        shader.bind()
        shader.uniform_float("viewportSize", gpu.state.viewport_get()[2:])
        shader.uniform_float("lineWidth", width)
    with gpu.matrix.push_pop():
        gpu.matrix.multiply_matrix(Matrix(np.asarray(model_matrix).tolist()))
        batch.draw(shader)
    gpu.state.depth_test_set('NONE')
    gpu.state.blend_set('NONE')


def draw_segments(starts, ends, colors, xray, width):
    """World-space segments (N,3)-(N,3), one RGBA colour each; wide ones with the polyline shader."""
    positions = np.ascontiguousarray(np.stack([starts, ends], axis=1).reshape(-1, 3), dtype=np.float32)
    shader = THICK if width > 1.0 else THIN
    batch = make_batch('LINES', positions, np.repeat(colors, 2, axis=0), shader_name=shader)
    draw_batch(batch, np.identity(4), xray, shader, width)


def draw_points(points, color, xray, size):
    """World-space points (N,3) in one RGBA colour, `size` pixels across."""
    if len(points) == 0:
        return
    positions = np.ascontiguousarray(points, dtype=np.float32)
    colors = np.tile(np.asarray(color, dtype=np.float32), (len(points), 1))
    draw_batch(make_batch('POINTS', positions, colors), np.identity(4), xray, point_size=size)


def _draw_boxes():
    context = bpy.context
    scene = context.scene
    settings = scene.raylab
    if not settings.show:
        return
    depsgraph = context.evaluated_depsgraph_get()
    for obj in structure_cache.target_objects(scene, context.view_layer):
        geometry = line_geometry(obj, scene, depsgraph)
        if geometry is None or geometry.box_count == 0:
            continue
        if geometry.batch is None:
            geometry.batch = make_batch('LINES', geometry.positions, geometry.colors, geometry.indices)
        entry = structure_cache.structure_for(obj, settings, depsgraph)
        draw_batch(geometry.batch, entry.model_matrix(obj), settings.xray)


# --- the ray object, live updates, spin -----------------------------------------------------------

PROBE_OBJECT_NAME = "raylab ray"


def ensure_probe_object(scene):
    """The scene's ray object (scene.raylab.probe_object), created if missing: an Empty drawn as a
    single arrow named "raylab ray". The ray leaves its origin along its local -Z axis; a new one is
    placed in front of the shown meshes (along -Y) aiming at their centre."""
    settings = scene.raylab
    if settings.probe_object is not None and settings.probe_object.name in scene.objects:
        return settings.probe_object
    obj = scene.objects.get(PROBE_OBJECT_NAME)
    if obj is None:
        obj = bpy.data.objects.new(PROBE_OBJECT_NAME, None)
        obj.empty_display_type = 'SINGLE_ARROW'
        scene.collection.objects.link(obj)
        centre, radius = _targets_sphere(scene)
        # Set as matrix_world so the probe sees the new place before the depsgraph re-evaluates.
        obj.matrix_world = (Matrix.Translation((centre[0], centre[1] - 3.0 * radius, centre[2]))
                            @ Matrix.Rotation(math.pi / 2, 4, 'X'))  # local -Z onto world +Y
        obj.empty_display_size = radius
    settings.probe_object = obj
    return obj


def _targets_sphere(scene):
    corners = [structure_cache.transform_points(structure_cache.matrix_of(o), np.array(o.bound_box))
               for o in structure_cache.target_objects(scene)]
    if not corners:
        return np.zeros(3), 1.0
    corners = np.concatenate(corners)
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    return (lo + hi) / 2, max(float(np.linalg.norm(hi - lo)) / 2, 0.1)


def tag_redraw():
    wm = bpy.context.window_manager
    for window in getattr(wm, "windows", []):
        for area in window.screen.areas:
            if area.type == 'VIEW_3D':
                area.tag_redraw()


def spin_step(scene):
    """Turns the shown mesh objects about Z by one step."""
    for obj in structure_cache.target_objects(scene):
        obj.rotation_euler.z += SPIN_STEP


def _spin_tick():
    scene = bpy.context.scene
    if scene is None or not scene.raylab.spin:
        return None  # stops the timer
    spin_step(scene)
    return SPIN_INTERVAL


def update_spin_timer():
    spinning = any(s.raylab.spin for s in bpy.data.scenes)
    registered = bpy.app.timers.is_registered(_spin_tick)
    if spinning and not registered:
        bpy.app.timers.register(_spin_tick, first_interval=SPIN_INTERVAL)
    elif not spinning and registered:
        bpy.app.timers.unregister(_spin_tick)


@bpy.app.handlers.persistent
def _on_frame_change(scene, *_):
    if scene.raylab.spin:
        spin_step(scene)
    tag_redraw()


@bpy.app.handlers.persistent
def _on_depsgraph_update(scene, depsgraph):
    tag_redraw()


@bpy.app.handlers.persistent
def _on_load(_):
    _geometry.clear()
    update_spin_timer()


_handles = []


def register():
    _handles.append(bpy.types.SpaceView3D.draw_handler_add(_draw_boxes, (), 'WINDOW', 'POST_VIEW'))
    bpy.app.handlers.frame_change_post.append(_on_frame_change)
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph_update)
    bpy.app.handlers.load_post.append(_on_load)


def unregister():
    for handle in _handles:
        bpy.types.SpaceView3D.draw_handler_remove(handle, 'WINDOW')
    _handles.clear()
    bpy.app.handlers.frame_change_post.remove(_on_frame_change)
    bpy.app.handlers.depsgraph_update_post.remove(_on_depsgraph_update)
    bpy.app.handlers.load_post.remove(_on_load)
    if bpy.app.timers.is_registered(_spin_tick):
        bpy.app.timers.unregister(_spin_tick)
    _geometry.clear()
