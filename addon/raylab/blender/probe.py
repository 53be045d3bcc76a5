"""The ray probe: one ray (from the ray object, or from the camera through a pixel) traced through the
scene model's raylab.Scene (structure_cache: the shown objects, as the renderer models them) with the
core's single-ray story, drawn in the viewport with its status text; optionally a fan of N×N rays
coloured by the status each ray's story would give.

Everything drawn and written comes from the story: its counters are the renderer's for that ray
(the top level included), each queried object's boxes are drawn in its own space with its matrix,
and a ray's t is the same in world and object space (the core does not renormalise the direction).

API for the levels:
    evaluate_probe(context_or_scene) -> dict(status, triangle_tests, triangle_total, box_tests,
                                             nodes_visited, hit_point): the counters as the core names them
"""
import math

import bpy
import numpy as np
from mathutils import Matrix, Vector

from .. import api
from . import draw, properties, scene_export, structure_cache

STATUSES = api.RAY_STATUSES  # in rising priority
STATUS_COLORS = {
    "missed_root": (0.62, 0.62, 0.70, 1.0),
    "missed_nodes": (1.00, 0.55, 0.10, 1.0),
    "missed_triangles": (1.00, 0.90, 0.10, 1.0),
    "hit_object": (0.20, 0.85, 1.00, 1.0),
}
VISITED_COLOR = (1.0, 1.0, 0.55, 1.0)
MISSED_BOX_COLOR = (1.0, 0.3, 0.25, 0.55)
ENTRY_COLOR = (1.0, 1.0, 1.0, 1.0)
HIT_COLOR = (1.0, 0.15, 0.55, 1.0)
TEXT_COLOR = (0.92, 0.92, 0.92, 1.0)
BACKDROP_COLOR = (0.0, 0.0, 0.0, 0.8)  # behind the status text: it stays readable over yellow boxes
LINE_SPACING = 1.5  # the status text's baselines, in font sizes
FAN_OBJECT_HALF_ANGLE = math.radians(20.0)  # the ray object's fan: a 40° pyramid around its +Z axis
# A fan with more rays than this draws lines for an even sample of them, and a dot where every ray
# ends (a density that stays readable): a 64×64 fan of lines would cover the whole view.
FAN_LINES_DRAWN = 256
# The ray leaves the ray object's origin along its local +Z: where its Single Arrow points.
RAY_AXIS = (0.0, 0.0, 1.0)


def aim_matrix(origin, direction):
    """The ray object's matrix_world for a ray from `origin` along `direction` (world space)."""
    return Matrix.Translation(origin) @ Vector(direction).to_track_quat('Z', 'Y').to_matrix().to_4x4()


# What the probe says of a ray, in the words the levels' tutorials use (tests/blender/test_level_texts.py
# reads both): a tree's four statuses by name (Octree 2, BVH 2), then what each means for the structure
# shown; an AABB's three cases as AABB 2 names them (one box, no inner nodes: what a tree calls
# missed_nodes or missed_triangles is "box hit, object missed").
STATUS_WORDS = {
    "missed_root": "missed_root: the ray misses {root}, it is ignored",
    "missed_root_top": "missed_root: the ray misses every object's box, before {root}: ignored",
    "missed_nodes": "missed_nodes: it enters the root but only crosses empty space",
    "missed_triangles": "missed_triangles: it crosses boxes with triangles, tests them, and hits none",
    "hit_object": "hit_object: it hits a triangle",
}
# The AABB's three cases, opening with the status as every structure's do (AABB 2 names the cases after them).
BOX_WORDS = {
    "missed_root": "missed_root: the ray misses the box, it is ignored",
    "missed_nodes": "missed_nodes: the ray enters the box but passes the object",
    "missed_triangles": "missed_triangles: the ray enters the box but passes the object",
    "hit_object": "hit_object: the ray hits a triangle",
}


def status_message(story, structure):
    """The first line of the probe's text: what happened to the ray (a SceneStory)."""
    status = story.status
    if status not in STATUS_WORDS:
        return ""
    if structure == "aabb":
        return BOX_WORDS[status]
    if status == "missed_root" and len(story.top_boxes["hit"]) and not story.top_boxes["hit"].any():
        status = "missed_root_top"  # the scene's top level culled it before any structure saw it
    return STATUS_WORDS[status].format(root=api.STRUCTURE_INFO[structure]["root_name"])


# --- rays ------------------------------------------------------------------------------------------

def _scene_of(context_or_scene):
    return context_or_scene if isinstance(context_or_scene, bpy.types.Scene) else context_or_scene.scene


def render_size(scene):
    """The camera's image in pixels, as the renderer makes it."""
    return api.image_size(scene_export.camera_dict(scene, scene.camera))


def camera_rays(scene, pixels):
    """World rays (origins (N,3), unit directions (N,3)) through pixel centres (N,2) (x from the
    left, y from the top, in the render's pixels): the renderer's own camera model."""
    pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    return api.camera_rays(scene_export.camera_dict(scene, scene.camera), pixels + 0.5)


def _object_rays(obj, directions_local):
    matrix = structure_cache.matrix_of(obj)
    directions = directions_local @ matrix[:3, :3].T
    lengths = np.linalg.norm(directions, axis=1, keepdims=True)
    if not np.all(lengths > 0):
        return None, None, f"The ray object '{obj.name}' is scaled to zero: its +Z axis points nowhere"
    return np.tile(matrix[:3, 3], (len(directions), 1)), directions / lengths, None


def probe_rays(scene, fan=False):
    """World rays of the probe: (origins, directions, None), or (None, None, why not). With fan=True
    the N×N fan: the camera's whole frame, or a pyramid around the ray object's +Z axis."""
    settings = scene.raylab
    n = settings.fan_size
    grid = (np.stack(np.meshgrid(np.arange(n), np.arange(n)), axis=-1).reshape(-1, 2) + 0.5) / n
    if settings.probe_source == 'CAMERA':
        if scene.camera is None:
            return None, None, "No camera in the scene"
        try:
            width, height = render_size(scene)
            pixels = grid * (width, height) - 0.5 if fan else [(settings.probe_pixel_x, settings.probe_pixel_y)]
            return (*camera_rays(scene, pixels), None)
        except (scene_export.ExportError, ValueError) as error:  # not a camera raylab can model
            return None, None, str(error)
    obj = settings.probe_object
    if obj is None:
        return None, None, "No ray object: pick one, or add one with the button"
    if fan:
        spread = math.tan(FAN_OBJECT_HALF_ANGLE) * (2.0 * grid - 1.0)
        local = np.concatenate([spread, np.ones((len(grid), 1))], axis=1)
    else:
        local = np.array([RAY_AXIS])
    return _object_rays(obj, local)


# --- evaluation ------------------------------------------------------------------------------------

class ProbeResult:
    """The public dict, the text, and what the viewport draws (all from the scene's stories)."""

    def __init__(self, key, public, text, drawing=None, fan=None):
        self.key = key
        self.public = public
        self.text = text
        self.drawing = drawing  # dict of world/object-space arrays, see _drawing()
        self.fan = fan          # (origins, ends, statuses, indices of the rays drawn as lines), world space


PROBE_COUNTERS = ("triangle_tests", "box_tests", "nodes_visited")  # of api.COUNTERS: what the probe shows


def counts_text(public):
    """The probe's counts line, in the counters' labels: "triangle tests 12 / 968, box tests 30, ..."."""
    parts = [f"{api.COUNTER_INFO[c]['label'].lower()} {public[c]:,}" for c in PROBE_COUNTERS]
    parts[0] += f" / {public['triangle_total']:,}"
    return ", ".join(parts)


def fan_work_text(rays, work):
    """The fan's summary line: its rays' work added up, in the counters' labels, and per ray, so that two
    structures compare at a glance: "fan of 1,024 rays: triangle tests 12,345 (12.1 a ray), ..."."""
    parts = [f"{api.COUNTER_INFO[c]['label'].lower()} {work[c]:,} ({work[c] / max(rays, 1):.1f} a ray)"
             for c in PROBE_COUNTERS]
    return f"fan of {rays:,} rays, in all: " + ", ".join(parts)


def _empty_public():
    return dict(status="", triangle_total=0, hit_point=None, fan_rays=0, fan_work=None,
                **dict.fromkeys(PROBE_COUNTERS, 0))


def _probe_key(scene, model):
    """Everything the probe's result depends on: the rays, the length, and the scene model's state."""
    settings = scene.raylab
    origins, directions, why_not = probe_rays(scene)
    fan = probe_rays(scene, fan=True) if settings.fan_enabled else (None, None, None)
    key = (why_not, None if origins is None else (origins.tobytes(), directions.tobytes()),
           settings.probe_length, None if fan[0] is None else (fan[0].tobytes(), fan[1].tobytes()),
           model.version)
    return key, (origins, directions, why_not), fan


def probe_result(scene, depsgraph=None):
    """The ProbeResult of the scene's probe (and fan) on the scene model's raylab.Scene, traced again
    only if anything it depends on changed: the rays, the objects' meshes, transforms or settings."""
    settings = scene.raylab
    model = structure_cache.scene_model(scene, depsgraph)
    key, (origins, directions, why_not), fan = _probe_key(scene, model)
    cached = _results.get(scene.name_full)
    if cached is not None and cached.key == key:
        return cached
    public = _empty_public()
    errors = model.errors()
    if why_not is not None:
        result = ProbeResult(key, public, [why_not])
    elif not model.committed or not model.instances:
        result = ProbeResult(key, public, errors[:1] or ["No mesh to probe"])
    else:
        story = model.scene.story(origins[0], directions[0])
        public.update(status=story.status, triangle_total=model.triangle_count(),
                      **{counter: int(story.stats[counter]) for counter in PROBE_COUNTERS})
        if story.hit is not None:
            public["hit_point"] = tuple(float(c) for c in origins[0] + story.hit["t"] * directions[0])
        text = [status_message(story, settings.structure), counts_text(public)]
        fan_drawing = None
        if fan[0] is not None:
            fan_drawing, fan_counts, fan_work = _trace_fan(model.scene, fan, settings.probe_length, settings.fan_size)
            text.append("fan: " + ", ".join(f"{fan_counts[s]:,} {s.replace('_', ' ')}" for s in reversed(STATUSES)))
            public.update(fan_rays=len(fan[0]), fan_work=fan_work)
            text.append(fan_work_text(len(fan[0]), fan_work))
        length = story.hit["t"] if story.hit is not None else settings.probe_length
        drawing = _drawing(story, origins[0], directions[0], length)
        result = ProbeResult(key, public, text + errors, drawing, fan_drawing)
    _results[scene.name_full] = result
    return result


def fan_lines(side):
    """Indices of the rays of a side×side fan drawn as lines: every k-th row and column, so that at most
    FAN_LINES_DRAWN are (all of them in a small fan)."""
    stride = max(1, math.ceil(side / math.isqrt(FAN_LINES_DRAWN)))
    kept = np.arange(0, side, stride)
    return (kept[:, None] * side + kept[None, :]).ravel()


def _trace_fan(traced_scene, fan, length, side):
    """The fan's rays in world space, ending at their hits (or after `length`), with the statuses the
    scene's stories would give them, the rays drawn as lines, how many rays have each status, and the
    work of all its rays added up ({counter: total} of PROBE_COUNTERS: what their stories count)."""
    origins, directions, _ = fan
    result = traced_scene.statuses(origins, directions)
    codes = result.status.astype(int)
    t = result.t.astype(np.float64)
    ends = origins + np.where(np.isfinite(t), t, length)[:, None] * directions
    counts = {s: int(np.sum(codes == i)) for i, s in enumerate(STATUSES)}
    stats = traced_scene.intersect(origins, directions, count=True).stats
    work = {c: int(stats[c]) for c in PROBE_COUNTERS}
    return (origins, ends, np.array(STATUSES)[codes], fan_lines(side)), counts, work


def _drawing(story, origin, direction, length):
    """What the viewport draws of the probe ray: the ray, each queried instance's boxes (in its object
    space, with its matrix), where the ray entered boxes and where it hit."""
    boxes, entries = [], []
    for part in story.instances:
        b = part.story.boxes
        visited = np.isin(b["node"], part.story.nodes) & b["hit"]
        tested_missed = ~b["hit"]
        boxes.append((part.instance, part.matrix.astype(np.float64), b["lo"][visited], b["hi"][visited],
                      b["lo"][tested_missed], b["hi"][tested_missed]))
        entry_t = np.asarray(b["t_entry"], dtype=np.float64)[b["hit"]]
        entries.append(origin + entry_t[:, None] * direction)  # the object ray keeps the world t
    hits = [] if story.hit is None else [origin + story.hit["t"] * direction]
    return dict(ray=(origin, origin + length * direction), boxes=boxes,
                entries=np.concatenate(entries) if entries else np.zeros((0, 3)),
                hits=np.array(hits, dtype=np.float64).reshape(-1, 3))


_results = {}  # scene name -> ProbeResult


def evaluate_probe(context_or_scene):
    """Evaluates the scene's probe ray (traced again if anything changed since); returns dict(status,
    triangle_tests, triangle_total, box_tests, nodes_visited, hit_point). status is one of STATUSES, or ""
    when there is no ray (no ray object / camera) or no mesh; hit_point is the world (x, y, z) of the
    nearest hit or None."""
    scene = _scene_of(context_or_scene)
    return dict(probe_result(scene).public)


def current_result(scene):
    """The last evaluation's public dict, evaluated again first if anything it depends on changed."""
    return probe_result(scene).public


def status_text(scene):
    return probe_result(scene).text


def last_status_text(scene):
    """The status lines of the probe's last trace, without tracing: what the sidebar panel shows. A
    panel's draw must never let go of Python's interpreter lock, which tracing does (render_engine's
    note on F12 says why); the viewport's draw traces and asks the panel to redraw when it changed."""
    cached = _results.get(scene.name_full)
    return cached.text if cached is not None else ["The probe is traced when the 3D view draws"]


# --- drawing (GUI only) ----------------------------------------------------------------------------

def _draw_view():
    context = bpy.context
    scene = context.scene
    settings = scene.raylab
    if not settings.probe_enabled:
        return
    before = _results.get(scene.name_full)
    result = probe_result(scene, context.evaluated_depsgraph_get())
    if result is not before:
        draw.tag_redraw(context)  # the sidebar shows last_status_text
    xray = settings.xray
    if result.fan is not None:
        origins, ends, statuses, lines = result.fan
        colors = np.array([STATUS_COLORS[s] for s in statuses], dtype=np.float32)
        colors[:, 3] = 0.7
        draw.draw_segments(origins[lines], ends[lines], colors[lines], xray, 1.0)
        if len(lines) < len(origins):
            draw.draw_points(ends, colors, xray, 3.0)
    drawing = result.drawing
    if drawing is None:
        return
    # The probe's own path is drawn over everything (as X-ray does), and the structure overlay is
    # dimmed meanwhile (overlay.PROBE_DIM), so the visited boxes stand out of a dense octree.
    for _, model, visited_lo, visited_hi, missed_lo, missed_hi in drawing["boxes"]:
        _draw_boxes(missed_lo, missed_hi, MISSED_BOX_COLOR, model, xray, 1.5)
        _draw_boxes(visited_lo, visited_hi, VISITED_COLOR, model, True, 3.0)
    start, end = drawing["ray"]
    color = np.array([STATUS_COLORS[result.public["status"]]], dtype=np.float32)
    draw.draw_segments(start[None], end[None], color, True, 3.0)
    draw.draw_points(drawing["entries"], ENTRY_COLOR, True, 7.0)
    draw.draw_points(drawing["hits"], HIT_COLOR, True, 12.0)


def _draw_boxes(lo, hi, color, model, xray, width):
    if len(lo) == 0:
        return
    positions, indices = draw.box_wireframe(lo, hi)
    colors = np.tile(np.asarray(color, dtype=np.float32), (len(positions), 1))
    batch = draw.make_batch('LINES', positions, colors, indices, draw.THICK)
    draw.draw_batch(batch, model, xray, draw.THICK, width)


drawn_backdrops = {}  # region pointer -> the status text's backdrop last drawn there (what the GUI tests read)


def text_backdrop(left, baseline, size, widths, scale=1.0):
    """The rectangle (x0, y0, x1, y1) in region pixels behind the status text's lines: the first baseline
    at `baseline`, each next LINE_SPACING font `size`s lower, `widths` their widths in pixels."""
    pad = 6 * scale
    bottom = baseline - (len(widths) - 1) * LINE_SPACING * size - 0.4 * size
    return left - pad, bottom - pad, left + max(widths, default=0) + pad, baseline + size + pad


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
    if result.text:
        backdrop = text_backdrop(left, y, size, [blf.dimensions(font, line)[0] for line in result.text], scale)
        _draw_backdrop(backdrop)
        drawn_backdrops[region.as_pointer()] = backdrop
    blf.enable(font, blf.SHADOW)
    blf.shadow(font, 3, 0.0, 0.0, 0.0, 0.9)
    for i, line in enumerate(result.text):
        color = STATUS_COLORS.get(result.public["status"], TEXT_COLOR) if i == 0 else TEXT_COLOR
        blf.color(font, *color)
        blf.position(font, left, y - i * size * LINE_SPACING, 0)
        blf.draw(font, line)
    blf.disable(font, blf.SHADOW)


def _draw_backdrop(rect):
    import gpu
    x0, y0, x1, y1 = rect
    positions = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], np.float32)
    colors = np.tile(np.asarray(BACKDROP_COLOR, np.float32), (4, 1))
    batch = draw.make_batch('TRIS', positions, colors, np.array([[0, 1, 2], [0, 2, 3]], np.uint32))
    gpu.state.blend_set('ALPHA')
    batch.draw(gpu.shader.from_builtin(draw.THIN))
    gpu.state.blend_set('NONE')


# --- the ray object and its operator ----------------------------------------------------------------------

PROBE_OBJECT_NAME = "raylab ray"


def ensure_probe_object(scene):
    """The scene's ray object (scene.raylab.probe_object), created if missing: an Empty drawn as a
    single arrow named "raylab ray". The ray leaves its origin along its local +Z axis, the arrow; a new one is
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
        obj.matrix_world = aim_matrix((centre[0], centre[1] - 3.0 * radius, centre[2]), (0.0, 1.0, 0.0))
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


class RAYLAB_OT_probe_add(bpy.types.Operator):
    """Add the ray object (an Empty "raylab ray"; the ray leaves along its arrow, local +Z) and turn the probe on"""
    bl_idname = "raylab.probe_add"
    bl_label = "Add Ray Object"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        settings = context.scene.raylab
        ensure_probe_object(context.scene)
        settings.probe_source = 'OBJECT'
        settings.probe_enabled = True
        return {'FINISHED'}


@bpy.app.handlers.persistent
def _on_load(_):
    _results.clear()


_handles = []


_register_classes, _unregister_classes = bpy.utils.register_classes_factory((RAYLAB_OT_probe_add,))


def register():
    properties.features.probe_result = current_result
    _register_classes()
    _handles.append((bpy.types.SpaceView3D.draw_handler_add(_draw_view, (), 'WINDOW', 'POST_VIEW'), 'WINDOW'))
    _handles.append((bpy.types.SpaceView3D.draw_handler_add(_draw_text, (), 'WINDOW', 'POST_PIXEL'), 'WINDOW'))
    bpy.app.handlers.load_post.append(_on_load)


def unregister():
    for handle, region in _handles:
        bpy.types.SpaceView3D.draw_handler_remove(handle, region)
    _handles.clear()
    bpy.app.handlers.load_post.remove(_on_load)
    _unregister_classes()
    properties.features.probe_result = None
    _results.clear()
