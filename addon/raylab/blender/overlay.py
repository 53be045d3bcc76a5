"""The structure overlay: every shown mesh object's boxes as wireframe, over the 3D viewport.

One GPU batch per object's structure (12 edges per box), cached and rebuilt only when the structure
or the filters change; the object's transform goes in as the model matrix, so moving an object
redraws the same batch. Dense octrees stay readable by fading deep boxes and boxes of structures
with many boxes, by the depth range and by showing the leaves alone (the core makes the arrays:
Structure.boxes(lines=True)).
"""
import bpy
import numpy as np
from . import draw, structure_cache
from .draw import draw_batch, make_batch

stats = {"batch_builds": 0}

# One colour per depth, repeating past the end: warm to cold, distinct next to each other.
DEPTH_PALETTE = np.array([
    (1.00, 0.25, 0.20), (1.00, 0.60, 0.10), (0.95, 0.95, 0.15), (0.35, 1.00, 0.25), (0.15, 0.95, 0.85),
    (0.25, 0.55, 1.00), (0.60, 0.35, 1.00), (1.00, 0.35, 0.85), (1.00, 1.00, 1.00), (0.60, 0.60, 0.60),
    (0.80, 0.55, 0.35),
], dtype=np.float32)
# Opaque RGBA rows, made once: a panel's draw reads them (numpy's copies let go of the interpreter lock,
# which a draw must not: levels.available_levels says why).
DEPTH_PALETTE_RGBA = np.concatenate([DEPTH_PALETTE, np.ones((len(DEPTH_PALETTE), 1), np.float32)], axis=1)

# While the probe is on, the boxes are drawn this faint, so that the probe's path stands out; while the
# cost heat map is on, fainter still: its cells are drawn after the boxes, over them (cost_overlay's
# CELL_ALPHA_OVER_BOXES), and the boxes around them stay as faint context.
PROBE_DIM = 0.3
COST_DIM = 0.2


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


def filter_key(settings):
    return (settings.depth_min, settings.depth_max, settings.leaves_only, settings.color_by_depth,
            settings.fade, tuple(round(c, 4) for c in settings.line_color), alpha_scale(settings))


# Other features that dim the boxes while they draw their own over them: (scene) -> factor (1: not dimmed).
DIMMERS = []


def alpha_scale(settings):
    """How strongly the boxes are drawn under the probe, the heat map or another feature's (1: alone)."""
    scale = COST_DIM if settings.cost_enabled else PROBE_DIM if settings.probe_enabled else 1.0
    for dimming in DIMMERS:
        scale *= dimming(settings.id_data)
    return scale


def box_palette(settings):
    """The colours by depth (the palette, opaque) or the one line colour, as (P,4) RGBA rows."""
    if settings.color_by_depth:
        return DEPTH_PALETTE_RGBA
    return np.asarray(settings.line_color, dtype=np.float32)[None, :]


def depth_key(settings, depths):
    """The key of the colours by depth: [(depth, (4,) RGBA)] of every depth in `depths` (those of the boxes
    drawn) inside the depth range, in the colour its boxes are drawn in (the palette repeats past its end)."""
    palette = box_palette(settings)
    shown = sorted({int(d) for d in depths if settings.depth_min <= d <= settings.depth_max})
    return [(depth, palette[depth % len(palette)]) for depth in shown]


def drawn_depths(scene, view_layer=None):
    """The depths of the boxes the overlay draws (leaves only, if so set) over every shown geometry whose
    structure is built, without building any (a panel's draw asks)."""
    depths = set()
    for entry in structure_cache.cached_entries(scene).values():
        if entry is not None and entry.structure is not None:
            depths |= entry.leaf_depths if scene.raylab.leaves_only else entry.depths
    return depths


def line_geometry(obj, scene, depsgraph=None):
    """The cached wireframe of `obj`'s structure for the scene's settings, rebuilt only when the
    structure or the filters changed; None when the structure is unavailable."""
    return geometry_of(obj.name_full, structure_cache.structure_for(obj, scene.raylab, depsgraph), scene.raylab)


def geometry_of(name, entry, settings):
    """The cached wireframe of geometry `name`'s Entry (see line_geometry)."""
    if entry is None or entry.structure is None:
        _geometry.pop(name, None)
        return None
    key = (entry.key, filter_key(settings))
    geometry = _geometry.get(name)
    if geometry is not None and geometry.key == key:
        return geometry
    # The core filters, colours and lays out the lines (Structure.boxes(lines=True)): numpy was too
    # slow for a deep octree (docs/bench/history.md).
    lines = entry.structure.boxes(lines=True, depth_min=settings.depth_min, depth_max=settings.depth_max,
                                  leaves_only=settings.leaves_only, palette=box_palette(settings),
                                  fade=settings.fade, alpha_scale=alpha_scale(settings))
    geometry = LineGeometry(key, lines["positions"], lines["colors"], lines["indices"], lines["box_count"])
    _geometry[name] = geometry
    stats["batch_builds"] += 1
    return geometry


# --- drawing (GUI only) ---------------------------------------------------------------------------

def _draw_boxes():
    context = bpy.context
    scene = context.scene
    settings = scene.raylab
    if not settings.show:
        return
    model = structure_cache.scene_model(scene, context.evaluated_depsgraph_get())
    # Each instance of a geometry (a collection instance's objects, geometry nodes' instances) draws the
    # geometry's one batch with its own matrix.
    for name, matrix in model.drawn():
        geometry = geometry_of(name, model.entry(name), settings)
        if geometry is None or geometry.box_count == 0:
            continue
        if geometry.batch is None:
            geometry.batch = make_batch('LINES', geometry.positions, geometry.colors, geometry.indices)
        draw_batch(geometry.batch, matrix, settings.xray)


# --- live updates --------------------------------------------------------------------------------

@bpy.app.handlers.persistent
def _on_frame_change(*_):
    draw.tag_redraw()


@bpy.app.handlers.persistent
def _on_depsgraph_update(scene, depsgraph):
    draw.tag_redraw()


@bpy.app.handlers.persistent
def _on_load(_):
    _geometry.clear()


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
    _geometry.clear()
