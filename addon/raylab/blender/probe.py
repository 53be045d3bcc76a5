"""The ray probe: one ray (from the ray object, or from the camera through a pixel) traced through
every shown object's structure with the core's single-ray story, drawn in the viewport with its
status text; optionally a fan of N×N rays coloured by what happened to each.

Everything drawn and written comes from the stories: the core traces the ray in object space (the
ray is carried there by the inverse of matrix_world; with the direction not renormalised, the ray
parameter t is the same in both spaces), and the results are carried back with matrix_world.

API for the levels:
    evaluate_probe(context_or_scene) -> dict(status, triangles_tested, triangle_total, boxes_tested,
                                             nodes_visited, hit_point)
"""
import math

import bpy
import numpy as np

from . import overlay, structure_cache

STATUSES = ("missed_root", "missed_nodes", "missed_triangles", "hit_object")  # in rising priority
STATUS_COLORS = {
    "missed_root": (0.62, 0.62, 0.70, 1.0),
    "missed_nodes": (1.00, 0.55, 0.10, 1.0),
    "missed_triangles": (1.00, 0.90, 0.10, 1.0),
    "hit_object": (0.20, 0.85, 1.00, 1.0),
}
ROOT_NAMES = {"aabb": "the AABB", "octree": "the octree root", "grid": "the grid's bounds", "bvh": "the BVH root"}
VISITED_COLOR = (1.0, 1.0, 0.55, 1.0)
MISSED_BOX_COLOR = (1.0, 0.3, 0.25, 0.55)
ENTRY_COLOR = (1.0, 1.0, 1.0, 1.0)
HIT_COLOR = (1.0, 0.15, 0.55, 1.0)
TEXT_COLOR = (0.92, 0.92, 0.92, 1.0)
FAN_STORY_LIMIT = 64       # fans of at most this many rays tell a story per ray
FAN_OBJECT_HALF_ANGLE = math.radians(20.0)  # the ray object's fan: a 40° pyramid around its -Z axis


def status_message(status, structure):
    if status == "missed_root":
        return f"Ray ignored: missed {ROOT_NAMES.get(structure, 'the root')}"
    if status == "missed_nodes":
        return "Hit the box, missed the object (no node with triangles entered)"
    if status == "missed_triangles":
        return "Entered nodes with triangles, hit none"
    if status == "hit_object":
        return "Hit the object"
    return ""


# --- rays ------------------------------------------------------------------------------------------

def _scene_of(context_or_scene):
    return context_or_scene if isinstance(context_or_scene, bpy.types.Scene) else context_or_scene.scene


def _camera_frame(scene, camera):
    """Camera-space (left, right, bottom, top, z) of the image plane, from Blender's own frame."""
    frame = np.array([tuple(v) for v in camera.data.view_frame(scene=scene)])
    return frame[:, 0].min(), frame[:, 0].max(), frame[:, 1].min(), frame[:, 1].max(), frame[0, 2]


def render_size(scene):
    r = scene.render
    return (max(1, round(r.resolution_x * r.resolution_percentage / 100)),
            max(1, round(r.resolution_y * r.resolution_percentage / 100)))


def camera_rays(scene, pixels):
    """World rays (origins (N,3), unit directions (N,3)) through pixel centres (N,2) (x from the
    left, y from the top, in the render's pixels)."""
    camera = scene.camera
    width, height = render_size(scene)
    left, right, bottom, top, z = _camera_frame(scene, camera)
    pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    x = left + (pixels[:, 0] + 0.5) / width * (right - left)
    y = top - (pixels[:, 1] + 0.5) / height * (top - bottom)
    matrix = structure_cache.matrix_of(camera)
    if camera.data.type == 'ORTHO':
        local = np.stack([x, y, np.zeros_like(x)], axis=1)
        origins = structure_cache.transform_points(matrix, local)
        directions = np.tile(matrix[:3, :3] @ (0.0, 0.0, -1.0), (len(x), 1))
    else:
        origins = np.tile(matrix[:3, 3], (len(x), 1))
        directions = np.stack([x, y, np.full_like(x, z)], axis=1) @ matrix[:3, :3].T
    return origins, directions / np.linalg.norm(directions, axis=1, keepdims=True)


def _object_rays(obj, directions_local):
    matrix = structure_cache.matrix_of(obj)
    directions = directions_local @ matrix[:3, :3].T
    lengths = np.linalg.norm(directions, axis=1, keepdims=True)
    if not np.all(lengths > 0):
        return None, None, f"The ray object '{obj.name}' is scaled to zero: its -Z axis points nowhere"
    return np.tile(matrix[:3, 3], (len(directions), 1)), directions / lengths, None


def probe_rays(scene, fan=False):
    """World rays of the probe: (origins, directions, None), or (None, None, why not). With fan=True
    the N×N fan: the camera's whole frame, or a pyramid around the ray object's -Z axis."""
    settings = scene.raylab
    n = settings.fan_size
    grid = (np.stack(np.meshgrid(np.arange(n), np.arange(n)), axis=-1).reshape(-1, 2) + 0.5) / n
    if settings.probe_source == 'CAMERA':
        if scene.camera is None:
            return None, None, "No camera in the scene"
        if fan:
            width, height = render_size(scene)
            return (*camera_rays(scene, grid * (width, height) - 0.5), None)
        return (*camera_rays(scene, [(settings.probe_pixel_x, settings.probe_pixel_y)]), None)
    obj = settings.probe_object
    if obj is None:
        return None, None, "No ray object: pick one, or add one with the button"
    if fan:
        spread = math.tan(FAN_OBJECT_HALF_ANGLE) * (2.0 * grid - 1.0)
        local = np.concatenate([spread, -np.ones((len(grid), 1))], axis=1)
    else:
        local = np.array([[0.0, 0.0, -1.0]])
    return _object_rays(obj, local)


# --- evaluation ------------------------------------------------------------------------------------

def _targets(scene):
    probe_object = scene.raylab.probe_object
    return [o for o in structure_cache.target_objects(scene) if o != probe_object]


class _Traced:
    """One object's structure and the ray carried into its space."""

    def __init__(self, obj, entry, origins, directions):
        self.obj = obj
        self.entry = entry
        self.model = entry.model_matrix(obj)
        inverse = np.linalg.inv(self.model)
        self.origins = structure_cache.transform_points(inverse, origins)
        self.directions = directions @ inverse[:3, :3].T


class ProbeResult:
    """The public dict, the text, and what the viewport draws (all from the stories)."""

    def __init__(self, key, public, text, drawing=None, fan=None):
        self.key = key
        self.public = public
        self.text = text
        self.drawing = drawing  # dict of world/object-space arrays, see _drawing()
        self.fan = fan          # (origins, ends, statuses) in world space


def _empty_public():
    return dict(status="", triangles_tested=0, triangle_total=0, boxes_tested=0, nodes_visited=0, hit_point=None)


def _combine(stories):
    """The ray's status over several objects: the most advanced case; the counts add up."""
    status = max((st.status for st in stories), key=STATUSES.index)
    return dict(status=status,
                triangles_tested=sum(int(st.stats["triangle_tests"]) for st in stories),
                boxes_tested=sum(int(st.stats["box_tests"]) for st in stories),
                nodes_visited=sum(int(st.stats["nodes_visited"]) for st in stories))


def _story_key(scene, targets, depsgraph):
    settings = scene.raylab
    origins, directions, why_not = probe_rays(scene)
    fan = probe_rays(scene, fan=True) if settings.fan_enabled else (None, None, None)
    entries = [structure_cache.structure_for(o, settings, depsgraph) for o in targets]
    key = (why_not, None if origins is None else (origins.tobytes(), directions.tobytes()),
           settings.probe_length, None if fan[0] is None else (fan[0].tobytes(), fan[1].tobytes()),
           tuple((o.name_full, e.key, structure_cache.matrix_of(o).tobytes()) for o, e in zip(targets, entries)))
    return key, (origins, directions, why_not), fan, entries


def probe_result(scene, depsgraph=None):
    """The ProbeResult of the scene's probe (and fan), traced again only if anything it depends on
    changed: the rays, the objects' structures or their transforms."""
    settings = scene.raylab
    targets = _targets(scene)
    key, (origins, directions, why_not), fan, entries = _story_key(scene, targets, depsgraph)
    cached = _results.get(scene.name_full)
    if cached is not None and cached.key == key:
        return cached
    public = _empty_public()
    if why_not is not None:
        result = ProbeResult(key, public, [why_not])
    elif not targets:
        result = ProbeResult(key, public, ["No mesh to probe"])
    else:
        errors = [e.error for e in entries if e.structure is None]
        traced = [_Traced(o, e, origins, directions) for o, e in zip(targets, entries) if e.structure is not None]
        if not traced:
            result = ProbeResult(key, public, errors[:1])
        else:
            stories = [t.entry.structure.story(t.origins[0], t.directions[0]) for t in traced]
            public.update(_combine(stories))
            public["triangle_total"] = sum(t.entry.structure.triangle_count for t in traced)
            hits = [(st.hit["t"], st, t) for st, t in zip(stories, traced) if st.hit is not None]
            nearest = min(hits, key=lambda h: h[0]) if hits else None
            if nearest is not None:
                public["hit_point"] = tuple(float(c) for c in origins[0] + nearest[0] * directions[0])
            text = [status_message(public["status"], settings.structure),
                    f"triangles tested {public['triangles_tested']} / {public['triangle_total']}, "
                    f"boxes tested {public['boxes_tested']}, nodes visited {public['nodes_visited']}"]
            fan_drawing = None
            if fan[0] is not None:
                fan_drawing, fan_counts = _trace_fan(_traced_fan(targets, entries, fan), fan, settings.probe_length)
                text.append("fan: " + ", ".join(f"{fan_counts[s]} {s.replace('_', ' ')}" for s in reversed(STATUSES)))
            length = nearest[0] if nearest is not None else settings.probe_length
            result = ProbeResult(key, public, text + errors,
                                 _drawing(traced, stories, origins[0], directions[0], length), fan_drawing)
    _results[scene.name_full] = result
    return result


def _traced_fan(targets, entries, fan):
    return [_Traced(o, e, fan[0], fan[1]) for o, e in zip(targets, entries) if e.structure is not None]


def fan_statuses(traced):
    """Per ray of a fan, the index into STATUSES for one object, and the hit distance (inf on miss).

    Small fans ask the story of every ray. Large ones trace all rays in one intersect call; a hit is
    'hit_object'; a miss that clearly misses the root box is 'missed_root'; the other misses are
    asked one by one with counting on, whose counters are the story's (a ray that tested triangles
    and hit none is 'missed_triangles'), so both ways give the story's status."""
    structure = traced.entry.structure
    origins, directions = traced.origins, traced.directions
    if len(origins) <= FAN_STORY_LIMIT:
        stories = [structure.story(o, d) for o, d in zip(origins, directions)]
        codes = np.array([STATUSES.index(st.status) for st in stories])
        t = np.array([st.hit["t"] if st.hit is not None else np.inf for st in stories])
        return codes, t
    hits = structure.intersect(origins, directions)
    codes = np.full(len(origins), 3)
    undecided = np.flatnonzero(~hits.hit)
    boxes = traced.entry.boxes()
    root = np.flatnonzero(boxes["depth"] == 0)
    if len(root):
        lo, hi = boxes["lo"][root[0]], boxes["hi"][root[0]]
        margin = 1e-4 * max(float(np.max(hi - lo)), 1e-6)
        clear_miss = ~_slab_hits(origins[undecided], directions[undecided], lo - margin, hi + margin)
        codes[undecided[clear_miss]] = 0
        undecided = undecided[~clear_miss]
    for i in undecided:
        counts = structure.intersect(origins[i], directions[i], count=True).stats
        codes[i] = 0 if counts["rays_ignored"] else 2 if counts["triangle_tests"] else 1
    return codes, hits.t.astype(np.float64)


def _slab_hits(origins, directions, lo, hi):
    """Whether rays (t >= 0) meet the box [lo, hi]; only used with a margin to skip sure misses."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / directions
        t0, t1 = (lo - origins) * inv, (hi - origins) * inv
        near = np.nanmax(np.minimum(t0, t1), axis=1)
        far = np.nanmin(np.maximum(t0, t1), axis=1)
    return (near <= far) & (far >= 0.0)


def _trace_fan(traced, fan, length):
    origins, directions, _ = fan
    codes = np.zeros(len(origins), dtype=int)
    t = np.full(len(origins), np.inf)
    for one in traced:
        c, tt = fan_statuses(one)
        codes = np.maximum(codes, c)
        t = np.minimum(t, tt)
    ends = origins + np.where(np.isfinite(t), t, length)[:, None] * directions
    counts = {s: int(np.sum(codes == i)) for i, s in enumerate(STATUSES)}
    return (origins, ends, np.array(STATUSES)[codes]), counts


def _drawing(traced, stories, origin, direction, length):
    """What the viewport draws of the probe ray: the ray, boxes (object space, per object), points."""
    boxes, entries = [], []
    for t, st in zip(traced, stories):
        b = st.boxes
        visited = np.isin(b["node"], st.nodes) & b["hit"]
        tested_missed = ~b["hit"]
        boxes.append((t.obj.name_full, t.model, b["lo"][visited], b["hi"][visited],
                      b["lo"][tested_missed], b["hi"][tested_missed]))
        entry_t = np.asarray(b["t_entry"], dtype=np.float64)[b["hit"]]
        entries.append(origin + entry_t[:, None] * direction)
    hit_points = [np.asarray(origin + st.hit["t"] * direction) for st in stories if st.hit is not None]
    return dict(ray=(origin, origin + length * direction), boxes=boxes,
                entries=np.concatenate(entries) if entries else np.zeros((0, 3)),
                hits=np.array(hit_points).reshape(-1, 3))


_results = {}  # scene name -> ProbeResult


def evaluate_probe(context_or_scene):
    """Evaluates the scene's probe ray (traced again if anything changed since); returns dict(status, triangles_tested, triangle_total,
    boxes_tested, nodes_visited, hit_point). status is one of STATUSES, or "" when there is no ray
    (no ray object / camera) or no mesh; hit_point is the world (x, y, z) of the nearest hit or None."""
    scene = _scene_of(context_or_scene)
    return dict(probe_result(scene).public)


def current_result(scene):
    """The last evaluation's public dict, evaluated again first if anything it depends on changed."""
    return probe_result(scene).public


def status_text(scene):
    return probe_result(scene).text


# --- drawing (GUI only) ----------------------------------------------------------------------------

def _draw_view():
    context = bpy.context
    scene = context.scene
    settings = scene.raylab
    if not settings.probe_enabled:
        return
    result = probe_result(scene, context.evaluated_depsgraph_get())
    xray = settings.xray
    if result.fan is not None:
        origins, ends, statuses = result.fan
        colors = np.array([STATUS_COLORS[s] for s in statuses], dtype=np.float32)
        colors[:, 3] = 0.7
        overlay.draw_segments(origins, ends, colors, xray, 1.0)
    drawing = result.drawing
    if drawing is None:
        return
    for _, model, visited_lo, visited_hi, missed_lo, missed_hi in drawing["boxes"]:
        _draw_boxes(missed_lo, missed_hi, MISSED_BOX_COLOR, model, xray, 1.5)
        _draw_boxes(visited_lo, visited_hi, VISITED_COLOR, model, xray, 3.0)
    start, end = drawing["ray"]
    color = np.array([STATUS_COLORS[result.public["status"]]], dtype=np.float32)
    overlay.draw_segments(start[None], end[None], color, xray, 3.0)
    overlay.draw_points(drawing["entries"], ENTRY_COLOR, xray, 7.0)
    overlay.draw_points(drawing["hits"], HIT_COLOR, xray, 12.0)


def _draw_boxes(lo, hi, color, model, xray, width):
    if len(lo) == 0:
        return
    positions, indices = overlay.box_wireframe(lo, hi)
    colors = np.tile(np.asarray(color, dtype=np.float32), (len(positions), 1))
    batch = overlay.make_batch('LINES', positions, colors, indices, overlay.THICK)
    overlay.draw_batch(batch, model, xray, overlay.THICK, width)


def _draw_text():
    import blf
    context = bpy.context
    scene = context.scene
    if not scene.raylab.probe_enabled:
        return
    result = probe_result(scene, context.evaluated_depsgraph_get())
    scale = context.preferences.system.ui_scale
    size = round(13 * scale)
    left = 12 * scale + sum(r.width for r in context.area.regions if r.type == 'TOOLS' and r.alignment == 'LEFT')
    # Below Blender's own view name and object lines in the same corner, which start below the headers
    # that overlap the view (4.x draws the view under its transparent header and tool header).
    region = context.region
    covered = sum(r.height for r in context.area.regions if r.type in {'HEADER', 'TOOL_HEADER'}
                  and region.y <= r.y < region.y + region.height)
    y = region.height - covered - 80 * scale
    font = 0
    blf.size(font, size)
    blf.enable(font, blf.SHADOW)
    blf.shadow(font, 3, 0.0, 0.0, 0.0, 0.9)
    for i, line in enumerate(result.text):
        color = STATUS_COLORS.get(result.public["status"], TEXT_COLOR) if i == 0 else TEXT_COLOR
        blf.color(font, *color)
        blf.position(font, left, y - i * size * 1.5, 0)
        blf.draw(font, line)
    blf.disable(font, blf.SHADOW)


# --- operator --------------------------------------------------------------------------------------

class RAYLAB_OT_probe_add(bpy.types.Operator):
    """Add the ray object (an Empty "raylab ray"; the ray leaves along its local -Z) and turn the probe on"""
    bl_idname = "raylab.probe_add"
    bl_label = "Add Ray Object"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        settings = context.scene.raylab
        overlay.ensure_probe_object(context.scene)
        settings.probe_source = 'OBJECT'
        settings.probe_enabled = True
        return {'FINISHED'}


@bpy.app.handlers.persistent
def _on_load(_):
    _results.clear()


_handles = []


def register():
    bpy.utils.register_class(RAYLAB_OT_probe_add)
    _handles.append((bpy.types.SpaceView3D.draw_handler_add(_draw_view, (), 'WINDOW', 'POST_VIEW'), 'WINDOW'))
    _handles.append((bpy.types.SpaceView3D.draw_handler_add(_draw_text, (), 'WINDOW', 'POST_PIXEL'), 'WINDOW'))
    bpy.app.handlers.load_post.append(_on_load)


def unregister():
    for handle, region in _handles:
        bpy.types.SpaceView3D.draw_handler_remove(handle, region)
    _handles.clear()
    bpy.app.handlers.load_post.remove(_on_load)
    bpy.utils.unregister_class(RAYLAB_OT_probe_add)
    _results.clear()
