"""Runs inside a real Blender window (xvfb-run, --enable-event-simulate): Compare Structures on the race
level with the dragon swapped in, as a student runs it from the sidebar.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup --enable-event-simulate START.blend \
        --python tests/gui/compare_session.py -- OUT_DIR

1. Started without a time limit, brute force renders the dragon for minutes: while it runs, a 0.1 s
   timer counts its ticks (the UI answers) and compare_running.png shows the panel's progress bar; then
   Esc (a simulated key press) cancels it and compare_cancelled.png shows the panel after it.
2. Started with a time limit of 5 s, it runs to its end; the structures estimated over the limit are
   not rendered in full: the table shows their numbers estimated from a sample, with a note. The panel at
   the sidebar's default width, scrolled to its end (compare_skipped.png: the last measures, the estimate's
   footnote and the notes) and to the table's start (compare_table.png); then dragged wider, a column
   per structure (compare_table_wide.png). What text_fit drew meanwhile
   (each line, its measured and its available width) goes into the report.
OUT_DIR/compare_session.json holds what was seen, or "error".
"""
import os
import sys
import threading
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import click_raylab_tab, screenshot, show_sidebar, view3d  # noqa: E402
from session import rect  # noqa: E402

OUT_DIR = session.out_dir()
report = {}
SESSION = session.Session(os.path.join(OUT_DIR, "compare_session.json"), report)
WATCHDOG_SECONDS = 500
TIME_LIMIT = 5.0
WHEEL_STEPS = 80  # more than the sidebar's height needs: the view stops at its end
TABLE_STEPS_UP = 34  # wheel steps back up from the end: the table's start (about 40 px each)
WIDEN = 260  # pixels the sidebar is dragged wider by, for a column per structure
EDGE_GRIP = 8  # pixels inside the sidebar's left edge where Blender's resize grip is (3.4, region overlap)
ticks = []


def workers():
    return sum(thread.name == "raylab compare" for thread in threading.enumerate())


def tick():
    """Counts the ticks that fire while a comparison runs: none would while a render blocked the UI."""
    from raylab.blender import compare
    if compare.running_job() is not None:
        ticks.append(time.monotonic())
    return 0.1


def scroll_sidebar_down(steps=WHEEL_STEPS, wheel='WHEELDOWNMOUSE'):
    """The Structure Comparison panel comes last, below the level's panels: wheel the sidebar down, as a
    user does (simulated wheel events, handled once this step returns). Not view2d.scroll_down inside an
    override: while the comparison's worker runs that could crash Blender 3.4 (blender_window.py)."""
    window, _, _, sidebar = view3d()
    x, y = sidebar.x + sidebar.width // 2, sidebar.y + sidebar.height // 2
    window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=x, y=y)
    for _ in range(steps):
        window.event_simulate(type=wheel, value='PRESS', x=x, y=y)
    window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=40, y=y)  # no tooltip in the screenshots


def compare_from_the_sidebar(**properties):
    window, area, _, sidebar = view3d()
    with bpy.context.temp_override(window=window, area=area, region=sidebar):
        return bpy.ops.raylab.compare_structures('INVOKE_DEFAULT', **properties)


def open_race():
    from raylab.blender import levels
    window, area, region, _ = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        assert bpy.ops.raylab.level_open(level_id="race") == {'FINISHED'}
        assert bpy.ops.raylab.level_swap_mesh(source="file:dragon.obj") == {'FINISHED'}
    report["triangles"] = len(levels.level_mesh_object(window.scene).data.polygons)
    show_sidebar()


def start_unlimited():
    report["started"] = sorted(compare_from_the_sidebar(time_limit=0.0))


def while_running():
    from raylab.blender import compare
    job = compare.running_job()
    report["running"] = dict(job=job is not None, ticks=len(ticks),
                             structure=job.current if job else None, workers=workers())
    window, _, _, sidebar = view3d()
    report["sidebar"], report["window_height"] = rect(sidebar), window.height
    scroll_sidebar_down()


def shoot_running():
    from raylab.blender import compare
    report["running"]["still_running"] = compare.running_job() is not None
    screenshot(os.path.join(OUT_DIR, "compare_running.png"))


def press_escape():
    window = view3d().window
    window.event_simulate(type='ESC', value='PRESS')
    window.event_simulate(type='ESC', value='RELEASE')


def wait_until(condition, timeout):
    """A step that returns only once condition() holds (the step timer calls it again meanwhile)."""
    deadline = []

    def step():
        if not deadline:
            deadline.append(time.monotonic() + timeout)
        return condition() or time.monotonic() >= deadline[0]
    return step


def after_cancel():
    from raylab.blender import compare
    scene = bpy.context.window_manager.windows[0].scene
    report["cancelled"] = dict(job=compare.running_job() is not None, workers=workers(),
                               stored=compare.COMPARISON in scene, skipped=compare.SKIPPED in scene)
    scroll_sidebar_down()


def start_limited():
    report["started_limited"] = sorted(compare_from_the_sidebar(time_limit=TIME_LIMIT))


def after_limited():
    from raylab.blender import compare, render_stats, text_fit
    scene = bpy.context.window_manager.windows[0].scene
    # {structure: whether its row is an estimate}
    report["limited"] = dict(job=compare.running_job() is not None, workers=workers(),
                             compared={k: render_stats.ESTIMATED_FROM in v
                                       for k, v in scene.get(compare.COMPARISON, {}).items()},
                             skipped={k: v for k, v in scene.get(compare.SKIPPED, {}).items()})
    text_fit.RECORD = []  # from now on, every line text_fit draws
    scroll_sidebar_down()


def table_texts(key):
    """report[key]: the table's texts as the panel lays them out at the sidebar's width, and every line
    text_fit drew since the last call (each with its measured and its available width)."""
    def step():
        from raylab.blender import compare, render_stats, text_fit
        scene = bpy.context.window_manager.windows[0].scene
        table = scene[compare.COMPARISON]
        sidebar = view3d().sidebar
        columns, sections = compare.table_layout(bpy.context, table, width=sidebar.width)
        report[key] = dict(columns=columns, sidebar_width=sidebar.width, ui_scale=text_fit.scale(bpy.context),
                           cells=[[title, [list(cell) for cell in cells]] for title, cells in sections],
                           note=render_stats.estimate_note(table["none"]),
                           drawn=[list(entry) for entry in text_fit.RECORD])
        text_fit.RECORD = []
    return step


def table_start():
    scroll_sidebar_down(TABLE_STEPS_UP, 'WHEELUPMOUSE')


def widen_sidebar():
    """The steps that drag the sidebar's left edge WIDEN pixels to the left, as a user does (simulated
    mouse events, one kind a step: Blender handles each before the next). The edge's grip lies a few
    pixels inside the region (EDGE_GRIP)."""
    def at(dx):
        window, _, _, sidebar = view3d()
        return window, sidebar.x + EDGE_GRIP + dx, sidebar.y + sidebar.height // 2

    def hover():
        window, x, y = at(0)
        window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=x, y=y)

    def press():
        window, x, y = at(0)
        window.event_simulate(type='LEFTMOUSE', value='PRESS', x=x, y=y)

    def drag():
        window, x, y = at(0)
        for step in range(1, 11):
            window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=x - WIDEN * step // 10, y=y)

    def release():
        window, x, y = at(0)  # the edge has moved with the pointer
        window.event_simulate(type='LEFTMOUSE', value='RELEASE', x=x, y=y)
        window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=40, y=y)
    return [hover, press, drag, release]


def job_over():
    from raylab.blender import compare
    return compare.running_job() is None


def shooter(name):
    return lambda: screenshot(os.path.join(OUT_DIR, name))


STEPS = [open_race, click_raylab_tab, scroll_sidebar_down, start_unlimited, lambda: None, while_running,
         shoot_running, press_escape, wait_until(job_over, 120.0), after_cancel, shooter("compare_cancelled.png"),
         start_limited, wait_until(job_over, 400.0), after_limited, shooter("compare_skipped.png"),
         table_texts("table"), table_start, shooter("compare_table.png"), *widen_sidebar(), scroll_sidebar_down,
         shooter("compare_table_wide.png"), table_texts("table_wide")]


def set_up():
    import raylab
    raylab.register()
    bpy.app.timers.register(tick, first_interval=0.1)


def progress():
    """A step done, or the comparison's fraction moving."""
    from raylab.blender import compare
    return len(STEPS), getattr(compare.running_job(), "fraction", None)


# A waiting step (wait_until) is called again half a second later.
SESSION.run(STEPS, set_up, wait=0.5, watchdog_seconds=WATCHDOG_SECONDS, progress=progress)
