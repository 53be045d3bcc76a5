"""Runs inside a real Blender window (xvfb-run, --enable-event-simulate): a scripted student opens every
level and does each task as its text says, through what a student uses (the sidebar's settings, the
operators behind its buttons, F12, moving objects), in every way the text allows (the goat or the ray,
a shipped mesh or one's own, the rod along every axis). The add-on's own handlers and timer tick the
tasks: this script only waits for them, one step at a time, from timers, and writes down the ticks the
Tasks panel shows after each step.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup START.blend --enable-event-simulate \
        --python tests/gui/student_session.py -- OUT_DIR

OUT_DIR/student_session.json: {"runs": [{"level", "way", "tasks": [text], "steps": [{"did", "expect",
"ticks", ...}], "error"?}], "seconds"} or "error"; "expect" is how many tasks should be ticked after the
step, in order. OUT_DIR/student_bvh_1_leaves_8.png and _leaves_1.png: BVH 1's viewport before and after
the leaf-size task.
"""
import json
import math
import os
import sys
import time
import traceback

import bpy
import numpy as np
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import draw_lock_watch  # noqa: E402
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import call_in_main_window, click_raylab_tab, screenshot, show_sidebar, start_f12, \
    view3d, viewport_shown  # noqa: E402

OUT_DIR = session.out_dir()
report = {"runs": []}
STARTED = time.monotonic()
SESSION = session.Session(os.path.join(OUT_DIR, "student_session.json"), report, indent=1,
                          finishing=lambda: report.update(seconds=round(time.monotonic() - STARTED, 1),
                                                          draws_letting_go=draw_lock_watch.found))
draw_lock_watch.start()
POLL = 0.25          # seconds between looks while waiting
SETTLE = 1.2         # a step that should tick nothing: the add-on's timer (every 0.5 s) has looked by then
TICK_WAIT = 45.0     # a step that should tick: the longest wait for it (a slow machine, a busy main loop)
JOB_WAIT = 400.0     # the heat maps or a comparison: the longest wait for it to end
RENDER_WAIT = 120.0  # F12 (320 x 240 to 480 x 360 pixels): the longest wait for its statistics
WATCHDOG_SECONDS = 240
ROD_MOVE = 2.0       # metres, as the rod task says

import raylab  # noqa: E402
from raylab.blender import compare, heat_maps, levels, probe, structure_cache, text_fit, tree_view  # noqa: E402


# --- what the student sees and does -------------------------------------------------------------------

def the_scene():
    return bpy.context.window_manager.windows[0].scene


def ticks():
    return [bool(done) for _, done in levels.task_list(the_scene())]


def wait_until(condition, limit):
    """Yields until condition() holds or `limit` seconds passed; returns whether it held."""
    deadline = time.monotonic() + limit
    while not condition():
        if time.monotonic() > deadline:
            return False
        yield POLL
    return True


def step(run, did, expect, **seen):
    """After the student did `did`, waits for the Tasks panel to show `expect` ticked tasks (or, when no
    new tick is due, lets the add-on's timer look), then writes down what it shows, and what else the
    student reads then: `seen`'s values, called if callable (the probe's status once the move is in)."""
    before = sum(ticks())
    if expect > before:
        yield from wait_until(lambda: sum(ticks()) >= expect, TICK_WAIT)
    else:
        yield SETTLE
    seen = {key: value() if callable(value) else value for key, value in seen.items()}
    run["steps"].append(dict(did=did, expect=expect, ticks=ticks(), at=round(time.monotonic() - STARTED, 1),
                             **seen))


def open_level(level_id):
    assert call_in_main_window(bpy.ops.raylab.level_open, level_id=level_id) == {'FINISHED'}
    yield 0.5  # let the window draw the new scene
    yield from wait_until(viewport_shown, TICK_WAIT)  # after a render, 3.x's workspace round trip
    if not report.get("sidebar"):  # once: the sidebar keeps its tab from level to level
        show_sidebar()
        yield 1.0
        click_raylab_tab()
        report["sidebar"] = True
        yield 0.5
    return the_scene()


def press(operator, **properties):
    """A button of the sidebar (its operator, invoked as a click does) in the main window's 3D viewport."""
    return call_in_main_window(operator, 'INVOKE_DEFAULT', **properties)


def wait_for_job():
    """A comparison or the heat maps: the modal operator stores its results when its job ends."""
    yield POLL
    assert (yield from wait_until(lambda: compare.running_job() is None, JOB_WAIT)), "the job did not end"


def render_f12():
    """F12, then wait for the render to end and store its statistics."""
    scene = the_scene()
    before = json.dumps(scene.get("raylab_last_render").to_dict() if "raylab_last_render" in scene else None)

    def stored():
        now = scene.get("raylab_last_render")
        return not bpy.app.is_job_running('RENDER') and now is not None and json.dumps(now.to_dict()) != before
    start_f12()
    yield POLL
    assert (yield from wait_until(stored, RENDER_WAIT)), \
        f"F12 stored no new render (the render job still running: {bpy.app.is_job_running('RENDER')})"


def heat_maps_again():
    assert press(bpy.ops.raylab.heat_maps) == {'RUNNING_MODAL'}
    yield from wait_for_job()
    return the_scene()[heat_maps.RECORD].to_dict()


def compare_structures():
    assert press(bpy.ops.raylab.compare_structures) == {'RUNNING_MODAL'}
    yield from wait_for_job()


def aim_ray(scene, wanted):
    """Drags the ray object sideways (G, its direction kept) to the nearest place where its ray ends as
    one of `wanted`, as a student tries places until the status says so. The places' statuses come from
    the scene's own model (what the probe traces) in one batch."""
    origins, directions, why_not = probe.probe_rays(scene)
    assert why_not is None, why_not
    direction = Vector(directions[0])
    across = direction.orthogonal().normalized()
    up = direction.cross(across).normalized()
    reach = 3.0 * levels.state(scene)["scene_scale"]
    steps = np.linspace(-reach, reach, 121)
    a, b = (g.ravel() for g in np.meshgrid(steps, steps))
    offsets = a[:, None] * np.array(across) + b[:, None] * np.array(up)
    offsets = offsets[np.argsort(np.hypot(a, b), kind="stable")]
    model = structure_cache.scene_model(scene)
    found = model.scene.statuses(origins[0] + offsets, np.tile(directions[0], (len(offsets), 1)))
    names = np.array(probe.STATUSES)[found.status.astype(int)]
    index = int(np.flatnonzero(np.isin(names, wanted))[0])
    ray = scene.raylab.probe_object
    ray.location = ray.location + Vector(offsets[index])


def status_of(scene):
    """The probe's status as the viewport's corner text shows it, read once the step's move is in."""
    return lambda: scene.raylab.probe_status


def add_own_mesh(operator):
    """Shift A in the 3D viewport: a new mesh object of the student's; returns its name."""
    before = set(bpy.data.objects.keys())
    assert call_in_main_window(operator, location=(3.0, 0.0, 0.0)) == {'FINISHED'}
    (name,) = set(bpy.data.objects.keys()) - before
    return name


def swap_mesh(source):
    assert call_in_main_window(bpy.ops.raylab.level_swap_mesh, source=source) == {'FINISHED'}


def viewport_shot(run, name):
    window, _, region, _ = view3d()
    path = os.path.join(OUT_DIR, name)
    screenshot(path)
    run.setdefault("shots", {})[name] = dict(region=dict(x=region.x, y=region.y, width=region.width,
                                                         height=region.height), window_height=window.height)


# --- the levels, as their texts tell them ---------------------------------------------------------------

def aabb_1(run):
    scene = yield from open_level("aabb_1")
    goat = levels.level_mesh_object(scene)
    scene.raylab.spin = False
    yield from step(run, "Spin off", 1)
    goat.location.x += 1.5
    yield from step(run, "G X 1.5", 2)
    goat.rotation_euler.x += math.radians(60.0)
    yield from step(run, "R X 60", 3)
    swap_mesh("file:bunny.obj")
    yield from step(run, "Level mesh: bunny.obj", 4)


def aabb_2_goat(run):
    scene = yield from open_level("aabb_2")
    goat = levels.level_mesh_object(scene)
    start = goat.location.copy()
    goat.location.z += 3.0
    yield from step(run, "G Z 3 on the goat: the ray passes under its box", 1,
                    status=status_of(scene))
    goat.location = start
    yield from step(run, "the goat back: the ray hits it (task 2 wants a miss)", 1,
                    status=status_of(scene))
    aim_ray(scene, ["missed_nodes", "missed_triangles"])
    yield from step(run, "the ray dragged into the box beside the goat", 2, status=status_of(scene))
    aim_ray(scene, ["hit_object"])
    yield from step(run, "the ray dragged onto the goat", 3, status=status_of(scene))
    text_fit.RECORD = []  # the panels' lines from now on: the Tasks panel shows the render's numbers
    yield from render_f12()
    yield from step(run, "F12", 4, rays_ignored=scene["raylab_last_render"].to_dict().get("rays_ignored"))
    run["render_under_tasks"] = yield from wait_until(
        lambda: any(line == "Last render (F12):" for line, _, _ in text_fit.RECORD), TICK_WAIT)
    text_fit.RECORD = None


def aabb_2_ray(run):
    scene = yield from open_level("aabb_2")
    aim_ray(scene, ["missed_root"])
    yield from step(run, "the ray dragged off the box", 1, status=status_of(scene))


def octree_1(run):
    scene = yield from open_level("octree_1")
    settings = scene.raylab
    settings.max_depth = 5
    yield from step(run, "Max depth 5", 1)
    settings.color_by_depth = True
    yield from step(run, "Colour by depth on", 2)
    settings.leaves_only = True
    yield from step(run, "Leaves only on", 3)
    settings.leaf_size = 2
    yield from step(run, "Leaf size 2", 4)
    settings.depth_min = 3
    yield from step(run, "Depth from 3", 5)


def octree_2(run):
    scene = yield from open_level("octree_2")
    for expect, status in enumerate(("missed_root", "missed_nodes", "missed_triangles"), 1):
        aim_ray(scene, [status])
        yield from step(run, f"the ray dragged to {status}", expect, status=status_of(scene))
    scene.raylab.max_depth = 6
    yield from step(run, "Max depth 6 (the ray still misses)", 3, status=status_of(scene))
    aim_ray(scene, ["hit_object"])
    yield from step(run, "the ray dragged onto the bunny", 4, status=status_of(scene),
                    triangle_tests=lambda: scene.raylab.probe_triangle_tests,
                    triangle_total=lambda: probe.current_result(scene)["triangle_total"])


def bvh_1(run):
    scene = yield from open_level("bvh_1")
    settings = scene.raylab
    settings.spin = False
    yield from step(run, "Spin off", 1)
    settings.depth_max = 3
    yield from step(run, "Depth to 3", 2)
    settings.leaves_only = True
    yield from step(run, "Leaves only on", 2)
    settings.depth_max = 64
    yield from step(run, "Depth to 64", 2)
    viewport_shot(run, "student_bvh_1_leaves_8.png")
    settings.leaf_size = 1
    yield from step(run, "Leaf size 1", 3)
    yield 1.0  # the overlay's new batch drawn
    viewport_shot(run, "student_bvh_1_leaves_1.png")
    name = add_own_mesh(bpy.ops.mesh.primitive_cube_add)
    yield from step(run, f"Shift A: {name}", 3)
    swap_mesh(f"object:{name}")
    yield from step(run, f"Level mesh: {name}", 4)


def read_tree(scene):
    return tree_view._last_read[scene.name_full]


def leaves(scene):
    parent = read_tree(scene).parent
    return np.bincount(parent[parent >= 0], minlength=len(parent)) == 0


def why_sah(run):
    scene = yield from open_level("why_sah")
    tree = scene.raylab_tree
    tree.enabled = True
    yield from step(run, "Tree view on", 1)
    yield from click_in_tree(run, scene)
    assert press(bpy.ops.raylab.tree_walk, step='ROOT') == {'FINISHED'}
    for _ in range(64):  # from the root down, the costliest child until a leaf
        if tree.picked_costliest:
            break
        assert press(bpy.ops.raylab.tree_walk, step='COSTLIEST') == {'FINISHED'}
        yield POLL
    # The path ends on the leaf that costs rays the most; the panel reads its share of the tree's cost.
    yield from step(run, "Costliest, down to a leaf", 2, node=lambda: tree.node,
                    costliest_leaf=lambda: int(np.argmax(np.where(leaves(scene), read_tree(scene).sah_cost, -1))),
                    panel=lambda: [text for text, _ in tree_view.node_lines(read_tree(scene), tree.node)])
    assert press(bpy.ops.raylab.tree_walk, step='PARENT') == {'FINISHED'}
    yield from step(run, "Up to its parent: the Split Explorer shows its splits", 3, node=lambda: tree.node)
    yield 1.0  # the view drawn with the picked node
    viewport_shot(run, "student_why_sah_tree.png")
    run["picked_box_pixels"] = picked_box_pixels(scene)
    run["tree_frame"] = list(tree_view.frames(view3d()[2])[0])
    scene.raylab.builder = "median"
    yield from step(run, "Builder: Object median", 4, cost_over_sah=lambda: tree.cost_over_sah)


def click_in_tree(run, scene):
    """Clicks the root's first child in the tree view, then presses Up with the pointer over the tree: writes
    down which node each picked."""
    yield from wait_until(lambda: view3d()[2].as_pointer() in tree_view._shown, TICK_WAIT)
    window, _, region, _ = view3d()
    _, picture, xs, ys = tree_view._shown[region.as_pointer()]
    aimed = int(picture["nodes"][1])  # depth-first: the root's first child
    x, y = region.x + int(round(xs[1])), region.y + int(round(ys[1]))
    window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=x, y=y)
    window.event_simulate(type='LEFTMOUSE', value='PRESS', x=x, y=y)
    window.event_simulate(type='LEFTMOUSE', value='RELEASE', x=x, y=y)
    yield 0.5
    run["click"] = dict(aimed=aimed, picked=scene.raylab_tree.node)
    window.event_simulate(type='UP_ARROW', value='PRESS', x=x, y=y)
    window.event_simulate(type='UP_ARROW', value='RELEASE', x=x, y=y)
    yield 0.5
    run["key_up"] = dict(parent=int(tree_view._last_read[scene.name_full].parent[aimed]),
                         picked=scene.raylab_tree.node)
    window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=region.x + region.width // 2,
                          y=region.y + region.height - 80)  # parked above the tree


def picked_box_pixels(scene):
    """Where the picked node's box corners fall in the 3D view's region, in pixels (None: off screen)."""
    from bpy_extras.view3d_utils import location_3d_to_region_2d
    _, area, region, _ = view3d()
    tree = tree_view._last_read[scene.name_full]
    node = tree.node(scene.raylab_tree.node)
    lo, hi = tree.lo[node], tree.hi[node]
    corners = np.array([[(hi if (c >> a) & 1 else lo)[a] for a in range(3)] for c in range(8)], np.float64)
    world = structure_cache.transform_points(structure_cache.matrix_of(levels.level_mesh_object(scene)), corners)
    pixels = [location_3d_to_region_2d(region, area.spaces.active.region_3d, Vector(p)) for p in world]
    return [None if p is None else [p.x, p.y] for p in pixels]


def bvh_2(run):
    scene = yield from open_level("bvh_2")
    aim_ray(scene, ["missed_nodes", "missed_triangles"])
    yield from step(run, "the ray dragged beside the cow", 1, status=status_of(scene))
    scene.raylab.fan_enabled = True
    yield from step(run, "Fan on", 2)
    scene.raylab.structure = "octree"
    yield from step(run, "Structure: Octree", 3, triangle_tests=lambda: scene.raylab.probe_triangle_tests)
    yield from render_f12()
    yield from step(run, "F12", 4)


def race(run):
    scene = yield from open_level("race")
    yield from compare_structures()
    yield from step(run, "Compare Structures", 1, compared=list(scene.get(compare.COMPARISON, {}).keys()))
    swap_mesh("file:dragon.obj")
    yield from step(run, "Level mesh: dragon.obj", 2)
    yield from compare_structures()
    yield from step(run, "Compare Structures again", 3, compared=list(scene.get(compare.COMPARISON, {}).keys()))
    obj = levels.level_mesh_object(scene)
    bpy.context.view_layer.objects.active = obj
    assert call_in_main_window(bpy.ops.object.modifier_add, type='WAVE') == {'FINISHED'}
    yield from step(run, "Add Modifier > Wave (the boxes still hidden)", 3)
    scene.raylab.show = True
    yield from step(run, "Show boxes on", 4)
    for update, expect in (("REFIT", 4), ("REBUILD", 5)):
        scene.raylab.animation_update = update
        frame, refits, builds = (scene.frame_current, structure_cache.stats["structure_refits"],
                                 structure_cache.stats["structure_builds"])
        screen = bpy.context.window_manager.windows[0].screen
        assert call_in_main_window(bpy.ops.screen.animation_play) == {'FINISHED'} and screen.is_animation_playing
        yield from wait_until(lambda: the_scene().frame_current >= frame + 3, 60.0)
        call_in_main_window(bpy.ops.screen.animation_cancel, restore_frame=False)  # 3.4 says PASS_THROUGH
        assert not screen.is_animation_playing
        yield from step(run, f"On animation: {update}, play", expect, frames=scene.frame_current - frame,
                        refits=structure_cache.stats["structure_refits"] - refits,
                        builds=structure_cache.stats["structure_builds"] - builds)


def where_work_goes(direction):
    """The rod moved ROD_MOVE metres along `direction` (an axis, either way). (That 1.5 m up is not
    enough, as the text says, tests/blender/test_levels.py checks.)"""
    def run_it(run):
        scene = yield from open_level("where_work_goes")
        record = yield from heat_maps_again()
        yield from step(run, "Render Heat Maps", 1, bvh_hardest=record["structures"]["bvh"]["hardest"])
        scene.raylab.probe_pixel_x, scene.raylab.probe_pixel_y = record["structures"]["octree"]["probe_pixel"]
        yield from step(run, "Pixel X, Y on the octree's hardest", 2,
                        triangle_tests=lambda: scene.raylab.probe_triangle_tests,
                        octree_hardest=record["structures"]["octree"]["hardest"])
        rod = scene.objects["Rod"]
        start = rod.location.copy()
        rod.location = start + Vector(direction) * ROD_MOVE
        record = yield from heat_maps_again()
        yield from step(run, f"the rod {ROD_MOVE} m along {direction}, Render Heat Maps", 3,
                        bvh_hardest=record["structures"]["bvh"]["hardest"])
    return run_it


def where_methods_fail(run):
    scene = yield from open_level("where_methods_fail")
    assert call_in_main_window(bpy.ops.raylab.level_leak_test) == {'FINISHED'}
    yield from step(run, "Count Leaking Rays", 1)
    yield from render_f12()
    yield from step(run, "F12, Robust Offset off", 2)
    scene.raylab_render.robust_offset = True
    yield from step(run, "Robust Offset on", 2)
    yield from render_f12()
    yield from step(run, "F12", 3)
    scene.raylab_render.shadow_terminator = True
    yield from step(run, "Shadow Terminator on", 3)
    yield from render_f12()
    yield from step(run, "F12", 4)


def sandbox_own(run):
    yield from open_level("sandbox")
    name = add_own_mesh(bpy.ops.mesh.primitive_monkey_add)
    yield from step(run, f"Shift A: {name}", 0)
    swap_mesh(f"object:{name}")
    yield from step(run, f"Level mesh: {name}", 1)


def sandbox_shipped(run):
    yield from open_level("sandbox")
    swap_mesh("file:bunny.obj")
    yield from step(run, "Level mesh: bunny.obj", 1)


ROD_WAYS = {"up": (0, 0, 1), "down": (0, 0, -1), "right": (1, 0, 0), "left": (-1, 0, 0), "away": (0, 1, 0),
            "toward": (0, -1, 0)}
# BVH 1's screenshots come before the first F12, whose render window would cover part of the viewport.
RUNS = [("aabb_1", "goat", aabb_1), ("octree_1", "sliders", octree_1), ("octree_2", "ray", octree_2),
        ("bvh_1", "own mesh", bvh_1), ("why_sah", "costliest path, median", why_sah),
        ("aabb_2", "goat", aabb_2_goat), ("aabb_2", "ray", aabb_2_ray),
        ("bvh_2", "ray", bvh_2), ("race", "goat then dragon", race)]
RUNS += [("where_work_goes", f"rod {way}", where_work_goes(axis)) for way, axis in ROD_WAYS.items()]
RUNS += [("where_methods_fail", "renders", where_methods_fail), ("sandbox", "own mesh", sandbox_own),
         ("sandbox", "shipped mesh", sandbox_shipped)]


# --- the driver: one run after the other, each a generator of waits -----------------------------------

current = {}


def drive():
    """The session's one step: the seconds until it is called again, or None once every run is done."""
    if "steps" not in current:
        if not RUNS:
            return None
        level_id, way, script = RUNS.pop(0)
        run = dict(level=level_id, way=way, steps=[],
                   tasks=[task.text for task in levels.find_level(level_id).tasks])
        report["runs"].append(run)
        current.update(steps=script(run), run=run)
    try:
        return next(current["steps"])
    except StopIteration:
        current.clear()
        return 0.5
    except Exception:
        current["run"]["error"] = traceback.format_exc()
        current.clear()
        return 0.5


SESSION.run([drive], raylab.register, first_interval=3.0, watchdog_seconds=WATCHDOG_SECONDS,
            what=lambda: f"the student ({len(RUNS)} runs left)",
            progress=lambda: (sum(len(r["steps"]) for r in report["runs"]), len(report["runs"]),
                              getattr(compare.running_job(), "fraction", None), the_scene().frame_current))
