"""The leak experiment of the where_methods_fail level: rays shot from inside the closed level mesh
through its vertices and edge midpoints, with each triangle test, slip out between two triangles when
the test is not watertight. The experiment owns its parts: the test itself (results on the scene under
scene["raylab_leak_test"]), its operator (Count Leaking Rays), its overlay and its lines in the level's
Tasks panel.

The overlay: after Count Leaking Rays, the rays that Möller–Trumbore let out of the closed level mesh
are drawn in red, from the centre of the mesh's box out through the vertex or edge where they slipped
between two triangles (a yellow dot), and on beyond the surface; over them, in the price chart's colour of
the fast contract, the rays the BVH lets out under the sidebar's Contract (none under the exact one).
Drawn through the mesh: the rays start inside it.

The same rays give this mesh's point on the price chart (levels/where_methods_fail/diagrams/bench_price.png:
wrong answers per million hostile rays against speed): each contract's leaks per million of them, and its
rays per second through the BVH against the exact contract's, measured on them here. The viewport draws that
chart in its bottom-left corner, a point per contract, the sidebar's Contract ringed; the panel says it.
"""
import time

import bpy
import numpy as np

from ... import api
from .. import draw, level_panels, text_fit
from ..levels import LevelError, level_mesh_object, object_mesh_arrays
from ..mesh_data import mesh_fingerprint

LEAK_KEY = "raylab_leak_test"
MAX_LEAKS_DRAWN = 400
RAY_COLOR = (1.0, 0.15, 0.1, 0.9)
CROSSING_COLOR = (1.0, 0.85, 0.1, 1.0)
CONTRACT_COLOR = (1.0, 0.5, 0.05, 1.0)  # the fast contract's orange in the price chart (tools/bench/charts.py)
SPEED_ROUNDS = 3  # the speed of a contract on the leak rays: the fastest of this many runs
# The price chart's colours per contract, as the benchmark's chart draws them (tools/bench/charts.py).
PRICE_COLOURS = dict(zip(api.CONTRACTS, ((0.12, 0.47, 0.71, 1.0), CONTRACT_COLOR)))
PRICE_FRAME = (60, 24, 330, 190)  # the chart in the viewport's pixels: x, y (from the bottom left), width, height
ZERO_AT = 0.3                     # where 0 wrong per million sits on the log axis (tools/bench/charts.py)
WRONG_RANGE = (ZERO_AT / 2, 4e5)  # the wrong-per-million axis, log; its ticks below
WRONG_TICKS = ((ZERO_AT, "0"), (10, "10"), (1e3, "1k"), (1e5, "100k"))
RING = (1.0, 1.0, 1.0, 1.0)
OVERSHOOT = 1.6  # each ray is drawn to 1.6 times its distance from the centre to the surface


# --- the experiment -------------------------------------------------------------------------------

def leak_test(scene):
    """Shoots rays from the centre of the level mesh's box through every vertex and every edge midpoint,
    the places where two triangles meet, with each triangle test. From inside a closed mesh every ray
    must hit; the ones that hit nothing leaked. Stores and returns {rays, one count per name in
    api.TRIANGLE_TESTS, contracts, contract_escaped, contract_speed, centre, escaped, mesh}: contracts counts the
    same rays' leaks through the BVH under each contract (api.CONTRACTS: what the sidebar's Contract changes),
    contract_escaped holds where they passed through, contract_speed each contract's rays per second on them; the
    box centre and the points where up to MAX_LEAKS_DRAWN escaped rays of the leakiest test (spread over all of
    them) passed through (object space, flat lists), for the viewport to draw; `mesh` is the mesh_fingerprint they
    belong to."""
    obj = level_mesh_object(scene)
    if obj is None:
        raise LevelError("the scene is not a level (open one first)")
    vertices, triangles = object_mesh_arrays(obj)
    targets = np.concatenate([vertices] + [(vertices[triangles[:, i]] + vertices[triangles[:, (i + 1) % 3]]) / 2
                                           for i in range(3)]).astype(np.float32)
    centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
    directions = targets - centre
    keep = np.linalg.norm(directions, axis=1) > 0  # a vertex at the very centre gives no direction
    origins = np.repeat(centre[None].astype(np.float32), int(keep.sum()), axis=0)
    result = {"rays": int(keep.sum()), "centre": [float(c) for c in centre], "mesh": mesh_fingerprint(obj)}
    escaped = targets[:0]
    for test in api.TRIANGLE_TESTS:
        # Every triangle tested for every ray: the count measures the triangle test alone.
        structure = api.build(vertices, triangles, structure="none", triangle_test=test)
        missed = ~structure.intersect(origins, directions[keep]).hit
        result[test] = int(missed.sum())
        if missed.sum() > len(escaped):  # the viewport draws the leakiest test's escapes
            escaped = targets[keep][missed]
    result["contracts"], result["contract_escaped"], result["contract_speed"] = {}, {}, {}
    for contract in api.CONTRACTS:
        structure = api.build(vertices, triangles, structure="bvh", contract=contract)
        seconds = []
        for _ in range(SPEED_ROUNDS):
            start = time.perf_counter()
            missed = ~structure.intersect(origins, directions[keep]).hit
            seconds.append(time.perf_counter() - start)
        result["contracts"][contract] = int(missed.sum())
        result["contract_escaped"][contract] = spread(targets[keep][missed])
        result["contract_speed"][contract] = result["rays"] / max(min(seconds), 1e-9)
    result["escaped"] = spread(escaped)
    scene[LEAK_KEY] = result
    return result


def spread(points):
    """Up to MAX_LEAKS_DRAWN of `points` (N,3), spread over all of them, as a flat list (an ID property)."""
    chosen = np.linspace(0, len(points) - 1, min(len(points), MAX_LEAKS_DRAWN)).astype(int)
    return points[chosen].ravel().tolist()


# --- the overlay (GUI only) -------------------------------------------------------------------------

def leak_segments(scene, contract=None):
    """World-space starts, ends and surface crossings (each (N,3)) of the escaped rays to draw: the leakiest
    triangle test's, or with `contract` the BVH's under that contract; None if there are none, no leak test in
    this scene, or the level mesh changed since."""
    leaks = scene.get(LEAK_KEY)
    obj = level_mesh_object(scene)
    if leaks is None or obj is None or leaks.get("mesh") != mesh_fingerprint(obj):
        return None
    escaped = leaks.get("escaped") if contract is None else leaks.get("contract_escaped", {}).get(contract)
    if not escaped:
        return None
    matrix = np.array(obj.matrix_world)
    centre = np.asarray(leaks["centre"], dtype=float)
    crossings = np.asarray(escaped, dtype=float).reshape(-1, 3)
    ends = centre + OVERSHOOT * (crossings - centre)
    starts = np.repeat(centre[None], len(crossings), axis=0)
    return tuple(p @ matrix[:3, :3].T + matrix[:3, 3] for p in (starts, ends, crossings))


_drawn = {}  # scene name: whether the viewport drew escaped rays last time, for the panel's line


def _draw():
    scene = bpy.context.scene
    escaped = leak_segments(scene)
    _drawn[scene.name_full] = escaped is not None
    for segments, colour, width in ((escaped, RAY_COLOR, 2.0),
                                    (leak_segments(scene, scene.raylab.contract), CONTRACT_COLOR, 3.0)):
        if segments is None:
            continue
        starts, ends, crossings = segments
        draw.draw_segments(starts, ends, np.tile(np.array(colour, np.float32), (len(starts), 1)), True, width)
        draw.draw_points(crossings, CROSSING_COLOR, True, 6.0)


# --- the panel lines and the operator ------------------------------------------------------------------

def draw_results(layout, context):
    """The leak test's counts in the level's Tasks panel (a level_panels.TASK_SECTIONS hook)."""
    leaks = context.scene.get(LEAK_KEY)
    if leaks is None:
        return
    box = layout.box()
    text_fit.label(box, context, f"Leak test: {leaks['rays']:,} rays from inside", 'MOD_FLUIDSIM', boxes=1)
    for test, info in api.TRIANGLE_TEST_INFO.items():
        text_fit.label(box, context, f"{info['label']}: {leaks[test]:,} leaked", boxes=1)
    for line, icon in contract_lines(leaks, context.scene.raylab.contract):
        text_fit.label(box, context, line, icon, boxes=1)
    # What the viewport drew, not leak_segments: a panel's draw must not let go of Python's interpreter lock,
    # which the mesh's fingerprint (zlib) and numpy's products do.
    if _drawn.get(context.scene.name_full):
        text_fit.label(box, context, "Escaped rays: red in the viewport, the Contract's orange", 'INFO', boxes=1)


def contract_lines(leaks, chosen):
    """What each contract lets out through the BVH, the sidebar's Contract (`chosen`) marked: [(text, icon)]."""
    contracts = leaks.get("contracts")
    if not contracts:
        return []  # a leak test from before contracts were counted
    lines = [(f"BVH, {api.CONTRACT_INFO[name]['label']} contract: {contracts[name]:,} leaked"
              + (" (the sidebar's Contract)" if name == chosen else ""), 'RIGHTARROW' if name == chosen else 'NONE')
             for name in api.CONTRACTS if name in contracts]
    point = price_point(leaks, chosen)
    if point is not None:
        wrong, speed = point
        reference = api.CONTRACT_INFO[api.DEFAULTS["contract"]]["label"]
        lines.append((f"This mesh on the price chart, {api.CONTRACT_INFO[chosen]['label']} contract: "
                      f"{wrong:,.0f} wrong per million hostile rays, {speed:.2f}x the {reference} contract's "
                      f"speed on them", 'GRAPH'))
    return lines


def price_point(leaks, contract):
    """This mesh's point on the price chart under `contract`: (wrong answers per million of the leak test's
    hostile rays, its rays per second over the default (exact) contract's), or None (no speeds measured)."""
    speeds, reference = leaks.get("contract_speed"), api.DEFAULTS["contract"]
    if not speeds or contract not in speeds or reference not in speeds or not leaks["rays"]:
        return None
    return 1e6 * leaks["contracts"][contract] / leaks["rays"], speeds[contract] / speeds[reference]


def price_chart_layout(leaks, chosen, frame=PRICE_FRAME):
    """Where the price chart draws (no bpy, so the tests read it), or None (no speeds measured): the plot
    (x, y, width, height), the points [(contract, x, y, rgba)], the sidebar's Contract `chosen`, the axes'
    labels [(x, y, text, rgba)]. x: wrong answers per million of the leak test's rays (log, 0 at ZERO_AT),
    y: speed on them against the default (exact) contract's."""
    points = {name: price_point(leaks, name) for name in api.CONTRACTS}
    if any(point is None for point in points.values()):
        return None
    x0, y0, w, h = frame
    plot = (x0 + 40, y0 + 34, w - 52, h - 76)
    speeds = [speed for _, speed in points.values()]
    low, high = min([0.5] + speeds) * 0.9, max([2.0] + speeds) * 1.1
    lo, hi = np.log10(WRONG_RANGE[0]), np.log10(WRONG_RANGE[1])

    def to_pixel(wrong, speed):
        across = (np.log10(min(max(wrong, ZERO_AT), WRONG_RANGE[1])) - lo) / (hi - lo)
        return plot[0] + across * plot[2], plot[1] + (speed - low) / (high - low) * plot[3]
    placed = [(name, *to_pixel(*points[name]), PRICE_COLOURS.get(name, RING)) for name in points]
    white = (1.0, 1.0, 1.0, 1.0)
    labels = [(x0 + 8, y0 + h - 18, "This mesh on the price chart", white),
              (x0 + 8, y0 + h - 34, "speed on its rays (the exact contract's = 1)", white),
              (plot[0], y0 + 4, "wrong per million of its rays", white),
              (x0 + 4, plot[1] - 4, f"{low:.2g}", white), (x0 + 4, plot[1] + plot[3] - 8, f"{high:.2g}", white)]
    labels += [(to_pixel(wrong, low)[0] - 4, plot[1] - 16, text, white) for wrong, text in WRONG_TICKS]
    for name, x, y, colour in placed:
        label = api.CONTRACT_INFO[name]["label"] + (" (sidebar)" if name == chosen else "")
        width = draw.TEXT_WIDTH * len(label)
        labels.append((x + 10 if x + 10 + width < x0 + w else x - 10 - width, y + 6, label, colour))
    return plot, placed, chosen, labels


def _draw_price_chart():
    context = bpy.context
    scene = context.scene
    leaks = scene.get(LEAK_KEY)
    obj = level_mesh_object(scene)
    if leaks is None or obj is None or leaks.get("mesh") != mesh_fingerprint(obj):
        return
    layout = price_chart_layout(leaks, scene.raylab.contract)
    if layout is None:
        return
    (px, py, pw, ph), placed, chosen, labels = layout
    draw.pixel_frame(PRICE_FRAME)
    draw.pixel_lines(np.array([[px, py], [px, py + ph], [px, py], [px + pw, py]]), (0.62, 0.62, 0.7, 1.0))
    for name, x, y, colour in placed:
        draw.pixel_squares(np.array([x]), np.array([y]), 9, np.array([colour], np.float32))
        if name == chosen:
            draw.pixel_outline(x, y, 17, RING)
    for x, y, text, colour in labels:
        draw.pixel_text(x, y, text, colour)


class RAYLAB_OT_level_leak_test(bpy.types.Operator):
    """Shoot rays from the mesh's centre through its vertices and edges with each triangle test; count leaks"""
    bl_idname = "raylab.level_leak_test"
    bl_label = "Count Leaking Rays"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        try:
            result = leak_test(context.scene)
        except (LevelError, ValueError) as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        leaked = ", ".join(f"{info['label']} {result[test]:,}" for test, info in api.TRIANGLE_TEST_INFO.items())
        self.report({'INFO'}, f"raylab: of {result['rays']:,} rays, leaked: {leaked}")
        return {'FINISHED'}


_handles = []


_register_classes, _unregister_classes = bpy.utils.register_classes_factory((RAYLAB_OT_level_leak_test,))


def register():
    _register_classes()
    _handles.append(bpy.types.SpaceView3D.draw_handler_add(_draw, (), 'WINDOW', 'POST_VIEW'))
    _handles.append(bpy.types.SpaceView3D.draw_handler_add(_draw_price_chart, (), 'WINDOW', 'POST_PIXEL'))
    level_panels.TASK_SECTIONS.append(draw_results)


def unregister():
    _drawn.clear()
    if draw_results in level_panels.TASK_SECTIONS:
        level_panels.TASK_SECTIONS.remove(draw_results)
    for handle in _handles:
        bpy.types.SpaceView3D.draw_handler_remove(handle, 'WINDOW')
    _handles.clear()
    _unregister_classes()
