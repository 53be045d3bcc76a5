"""The viewport cost overlay: a low-resolution heat map over the 3D view of what each ray from the view
costs the current structure (box tests, triangle tests or nodes visited), with its legend.

The rays go through the centres of a grid of cells over the view (as many across as the setting asks,
square cells), from the view's near plane, on the scene model's raylab.Scene (structure_cache): the
structures the overlay draws and the probe traces. They are traced again only when the view, the region,
the scene model or the settings change, so orbiting traces a few thousand rays per redraw.

The costliest objects: a grid of cells over the scene camera's image (what F12 renders), one ray each,
each ray's work told apart by object. The core counts a ray's work for the whole scene; the scene's story of a
ray (raylab.Scene.story, the same traversal) says what each instance it entered did, so the objects'
counts add up exactly to the rays' counts. A story records every triangle it tests: when the rays test
more than RANK_BUDGET triangles together, every k-th ray that did work is told apart (and the panel says
how many were).
"""
import math

import bpy
import numpy as np

from .. import api
from . import draw, scene_export, structure_cache

LEGEND_STEPS = 32       # colour steps of the legend's bar
LEGEND_SIZE = (160, 12)  # the bar, in pixels
LEGEND_ORIGIN = (16, 40)  # its bottom-left corner in the region, clear of Blender's own corner text
CELL_ALPHA = 0.65       # a cell with no work is not drawn; the others let the shading show through
# Over the structure's boxes (drawn before the cells, in the 3D pass) a cell lets nothing through: hundreds
# of faint lines add up to green (a 0.92 cell still looked green over a dense octree); the boxes show
# around the cells, where no ray did any work.
CELL_ALPHA_OVER_BOXES = 1.0


def grid_size(width, height, cells_across):
    """(columns, rows) of square cells over a width × height region."""
    columns = max(1, min(int(cells_across), int(width)))
    return columns, max(1, round(columns * height / max(width, 1)))


def view_rays(perspective_matrix, columns, rows):
    """World rays ((N,3) origins on the near plane, (N,3) unit directions; float32) through the centres of
    columns × rows cells of a view whose perspective_matrix (4,4) is projection @ view; row 0 at the
    bottom, as Blender's region pixels count. Perspective and orthographic views alike."""
    x = (np.arange(columns) + 0.5) / columns * 2.0 - 1.0
    y = (np.arange(rows) + 0.5) / rows * 2.0 - 1.0
    grid_x, grid_y = np.meshgrid(x, y)
    inverse = np.linalg.inv(np.asarray(perspective_matrix, dtype=np.float64))

    def unproject(depth):
        points = np.stack([grid_x.ravel(), grid_y.ravel(), np.full(grid_x.size, depth), np.ones(grid_x.size)])
        world = inverse @ points
        return (world[:3] / world[3]).T

    near, far = unproject(-1.0), unproject(1.0)
    directions = far - near
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return near.astype(np.float32), directions.astype(np.float32)


class CostGrid:
    """One traced grid: the counts (rows, columns) of the chosen counter, and what they were traced for."""

    __slots__ = ("key", "counts", "columns", "rows", "batch")

    def __init__(self, key, counts):
        self.key = key
        self.counts = counts
        self.rows, self.columns = counts.shape
        self.batch = None


_grids = {}  # (scene name, region pointer) -> CostGrid


def cost_grid(scene, perspective_matrix, width, height, depsgraph=None, region_key=None):
    """The CostGrid of the scene's settings for a view (perspective_matrix, region width × height),
    traced again only if anything it depends on changed; None when no mesh is shown."""
    settings = scene.raylab
    model = structure_cache.scene_model(scene, depsgraph)
    if not model.committed or not model.instances:
        return None
    columns, rows = grid_size(width, height, settings.cost_cells)
    matrix = np.asarray(perspective_matrix, dtype=np.float64)
    key = (matrix.tobytes(), columns, rows, settings.cost_counter, model.version)
    grid = _grids.get((scene.name_full, region_key))
    if grid is not None and grid.key == key:
        return grid
    origins, directions = view_rays(matrix, columns, rows)
    hits = model.scene.intersect(origins, directions, per_ray=True)
    grid = CostGrid(key, hits.per_ray[settings.cost_counter].reshape(rows, columns))
    _grids[(scene.name_full, region_key)] = grid
    return grid


def quads(x0, y0, x1, y1):
    """Q axis-aligned rectangles in region pixels: positions (4Q,2) float32, triangle indices (2Q,3) uint32."""
    positions = np.stack([np.stack([x0, y0], 1), np.stack([x1, y0], 1), np.stack([x1, y1], 1),
                          np.stack([x0, y1], 1)], 1).reshape(-1, 2).astype(np.float32)
    base = 4 * np.arange(len(x0), dtype=np.uint32)[:, None, None]
    indices = (base + np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32)[None]).reshape(-1, 3)
    return positions, np.ascontiguousarray(indices, dtype=np.uint32)


def display_colours(values, maximum):
    """(N,4) RGBA of counts in the heat map's colours as the viewport shows them. raylab.heat_map gives
    linear colours, for renders; the viewport's drawing takes colours as they are shown (as the depth
    palette's and the probe's), so they go back through the sRGB curve: its top colour is the legend's
    pale yellow, not a darker one."""
    rgba = api.heat_map(np.asarray(values, np.float32), maximum).reshape(-1, 4)
    linear = rgba[:, :3]
    rgba[:, :3] = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055)
    return rgba


def cell_alpha(settings):
    return CELL_ALPHA_OVER_BOXES if settings.show else CELL_ALPHA


def cell_quads(counts, width, height, maximum, alpha=CELL_ALPHA):
    """The cells that did any work as region-pixel quads: positions (4Q,2), colours (4Q,4) on the fixed
    scale [0, maximum] with `alpha`, triangle indices (2Q,3)."""
    rows, columns = counts.shape
    row, column = np.nonzero(counts > 0)
    positions, indices = quads(column * width / columns, row * height / rows,
                               (column + 1) * width / columns, (row + 1) * height / rows)
    rgba = display_colours(counts[row, column], maximum)
    rgba[:, 3] = alpha
    return positions, np.repeat(rgba, 4, axis=0).astype(np.float32), indices


# --- the costliest objects -------------------------------------------------------------------------

RANK_COUNTER = "triangle_tests"  # what the objects are ranked by
RANK_CELLS = 48                  # cells across the camera's image: one ray each (a story is costly)
RANK_BUDGET = 250_000            # triangle tests the stories of one ranking may record (docs/bench/history.md)


class ObjectCosts:
    """Each shown object's triangle tests in the rays through the camera's image: counts[name], summed
    over `told` of the `rays` traced (every ray unless they tested more than RANK_BUDGET triangles)."""

    __slots__ = ("key", "rays", "told", "counts")

    def __init__(self, key, rays, told, counts):
        self.key, self.rays, self.told, self.counts = key, rays, told, counts

    def ranked(self):
        """[(name, triangle tests, share of all of them)] of every shown object, the costliest first (then
        by name)."""
        total = sum(self.counts.values())
        rows = sorted(self.counts.items(), key=lambda item: (-item[1], item[0]))
        return [(name, count, count / total if total else 0.0) for name, count in rows]


_costs = {}  # scene name -> (ObjectCosts or None, why none)


def camera_grid(camera):
    """Raster points (N,2) at the centres of RANK_CELLS across square cells over the camera's image."""
    width, height = api.image_size(camera)
    columns, rows = grid_size(width, height, RANK_CELLS)
    xs = (np.arange(columns) + 0.5) * width / columns
    ys = (np.arange(rows) + 0.5) * height / rows
    return np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)


def object_costs(scene, depsgraph=None):
    """(ObjectCosts of the scene camera's view, None), traced again only when the camera, the image or the
    scene model changed; (None, why not) without a camera raylab can model or a shown mesh.
    It traces (and lets go of Python's interpreter lock meanwhile): the viewport's draw calls it, a
    panel reads last_object_costs."""
    result = _object_costs(scene, depsgraph)
    _costs[scene.name_full] = result
    return result


def last_object_costs(scene):
    """What object_costs last found for the scene, without tracing: what the sidebar panel shows."""
    return _costs.get(scene.name_full, (None, "The objects are ranked when the 3D view draws"))


def _object_costs(scene, depsgraph):
    if scene.camera is None:
        return None, "No scene camera to look through"
    try:
        camera = scene_export.camera_dict(scene, scene.camera)
        points = camera_grid(camera)
    except (scene_export.ExportError, ValueError) as error:
        return None, str(error)
    model = structure_cache.scene_model(scene, depsgraph)
    if not model.committed or not model.instances:
        return None, model.error or "No shown mesh"
    key = (repr({k: v.tobytes() if isinstance(v, np.ndarray) else v for k, v in camera.items()}),
           len(points), model.version)
    costs = _costs.get(scene.name_full, (None,))[0]
    if costs is not None and costs.key == key:
        return costs, None
    origins, directions = api.camera_rays(camera, points)
    tmin = camera["clip_start"]  # where the render's camera rays start
    work = model.scene.intersect(origins, directions, tmin=tmin, per_ray=True).per_ray[RANK_COUNTER]
    step = max(1, math.ceil(int(work.sum(dtype=np.int64)) / RANK_BUDGET))
    told = np.flatnonzero(work)[::step]  # a ray that tested no triangle adds none to any object
    counts = dict.fromkeys(model.instances, 0)
    for ray in told:
        for part in model.scene.story(origins[ray], directions[ray], tmin=tmin).instances:
            counts[model.instances[part.instance]] += part.story.stats[RANK_COUNTER]
    return ObjectCosts(key, len(points), len(points) if step == 1 else len(told), counts), None


# --- drawing (GUI only) ----------------------------------------------------------------------------

def legend_title(settings, grid, errors=()):
    """The legend's line over its colour ramp: the counter, the structure and the hardest cell, or, when an
    object cannot be traced, why (a map without it would read "hardest here 0" and say nothing)."""
    label = api.COUNTER_INFO[settings.cost_counter]["label"]
    if errors:
        return f"{label} per ray: not traced, {errors[0]}"
    hardest = int(grid.counts.max()) if grid is not None else 0
    return f"{label} per ray ({settings.structure}); hardest here {hardest}"


def _draw_legend(settings, grid, errors=()):
    import blf
    import gpu
    width, height = LEGEND_SIZE
    x, y = LEGEND_ORIGIN
    values = (np.arange(LEGEND_STEPS, dtype=np.float32) + 0.5) / LEGEND_STEPS * settings.cost_maximum
    colors = display_colours(values, settings.cost_maximum)
    step = width / LEGEND_STEPS
    x0 = x + step * np.arange(LEGEND_STEPS)
    positions, indices = quads(x0, np.full_like(x0, y), x0 + step, np.full_like(x0, y + height))
    batch = draw.make_batch('TRIS', positions, np.repeat(colors, 4, axis=0).astype(np.float32), indices)
    gpu.state.blend_set('ALPHA')
    batch.draw(gpu.shader.from_builtin(draw.THIN))
    gpu.state.blend_set('NONE')
    font = 0
    blf.size(font, 12)
    blf.color(font, 1.0, 1.0, 1.0, 1.0)
    blf.position(font, x, y + height + 6, 0)
    blf.draw(font, legend_title(settings, grid, errors))
    for value, text in api.heat_ticks(settings.cost_maximum):
        fraction = value / settings.cost_maximum
        blf.position(font, x + fraction * width - (6 if fraction else 0), y - 16, 0)
        blf.draw(font, text)


def _draw_cost():
    context = bpy.context
    scene = context.scene
    settings = scene.raylab
    region, rv3d = context.region, context.region_data
    if settings.show or settings.cost_enabled:  # the Structure panel ranks the objects it lists
        before = _costs.get(scene.name_full)
        if object_costs(scene, context.evaluated_depsgraph_get()) != before:
            draw.tag_redraw(context)
    if not settings.cost_enabled or region is None or rv3d is None:
        return
    grid = cost_grid(scene, rv3d.perspective_matrix, region.width, region.height,
                     context.evaluated_depsgraph_get(), region.as_pointer())
    if grid is not None:
        look = (settings.cost_maximum, cell_alpha(settings), region.width, region.height)
        if grid.batch is None or grid.batch[0] != look:
            positions, colors, indices = cell_quads(grid.counts, region.width, region.height, settings.cost_maximum,
                                                    cell_alpha(settings))
            grid.batch = (look, draw.make_batch('TRIS', positions, colors, indices) if len(indices) else None)
        if grid.batch[1] is not None:
            import gpu
            gpu.state.blend_set('ALPHA')
            grid.batch[1].draw(gpu.shader.from_builtin(draw.THIN))
            gpu.state.blend_set('NONE')
    _draw_legend(settings, grid, structure_cache.scene_model(scene, context.evaluated_depsgraph_get()).errors())


@bpy.app.handlers.persistent
def _on_load(_):
    _grids.clear()
    _costs.clear()


_handles = []


def register():
    _handles.append(bpy.types.SpaceView3D.draw_handler_add(_draw_cost, (), 'WINDOW', 'POST_PIXEL'))
    bpy.app.handlers.load_post.append(_on_load)


def unregister():
    for handle in _handles:
        bpy.types.SpaceView3D.draw_handler_remove(handle, 'WINDOW')
    _handles.clear()
    bpy.app.handlers.load_post.remove(_on_load)
    _grids.clear()
    _costs.clear()
