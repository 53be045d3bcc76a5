"""In a real Blender window: opens the AABB 2 level and renders it (F12) once with each structure, while a
main-thread timer ticks every 20 ms; the longest gap between two ticks during each render is how long the
render held Blender's main loop (no event, no redraw meanwhile). Logs it per structure; asserts nothing
about time (the machine's load decides it).

    blender START.blend --python f12_stalls.py -- OUT_DIR

OUT_DIR/f12_stalls.json: {"stalls": {structure: {"longest_s", "render_s", "ticks", "finished"}}, "errors": [...]}.
"""
import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
import blender_window  # noqa: E402

OUT_DIR = session.out_dir()
LEVEL = session.ARGS[1] if len(session.ARGS) > 1 else "aabb_2"
report = {"level": LEVEL, "stalls": {}, "errors": []}
SESSION = session.Session(os.path.join(OUT_DIR, "f12_stalls.json"), report, indent=2, errors="errors")
TICK = 0.02
beat = {"last": None, "longest": 0.0, "ticks": 0, "on": False, "cpu": 0.0, "t0": 0.0}


TRACE = bool(os.environ.get("RAYLAB_STALL_TRACE"))  # also log each stall over 0.3 s and the job's phases


def heartbeat():
    main_loop_ran()
    return TICK


def main_loop_ran():
    """A main-thread timer ran (the heartbeat, or a step's wait): the gap since the last one is a stall."""
    now = time.perf_counter()
    if beat["on"] and beat["last"] is not None:
        beat["longest"] = max(beat["longest"], now - beat["last"])
        beat["ticks"] += 1
        if TRACE and now - beat["last"] > 0.3:
            note(f"main loop stalled {now - beat['last']:.3f} s from {beat['last'] - beat['t0']:.3f} "
                 f"(main thread's CPU meanwhile {time.thread_time() - beat['cpu']:.3f} s)")
    beat["last"] = now
    beat["cpu"] = time.thread_time()


def note(event):
    report.setdefault("trace", []).append(f"{time.perf_counter() - beat['t0']:.3f} {event}")


def traced(module, name):
    function = getattr(module, name)

    def wrapper(*args, **kwargs):
        note(f"{name} starts")
        try:
            return function(*args, **kwargs)
        finally:
            note(f"{name} ends")
    setattr(module, name, wrapper)


def open_level():
    window, area, region, _ = blender_window.view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        assert bpy.ops.raylab.level_open(level_id=LEVEL) == {'FINISHED'}
    # RAYLAB_F12_DISPLAY=NONE: no render window redrawn as tiles arrive, so what holds the main loop is the render
    bpy.context.preferences.view.render_display_type = os.environ.get("RAYLAB_F12_DISPLAY", 'WINDOW')
    bpy.app.timers.register(heartbeat, first_interval=0.0, persistent=True)


def render_with(structure, key=None):
    state = {}

    def start():
        from raylab.blender.render_stats import LAST_RENDER
        scene = bpy.context.window_manager.windows[0].scene
        scene.raylab.structure = structure
        if LAST_RENDER in scene:
            del scene[LAST_RENDER]
        beat.update(longest=0.0, ticks=0, on=True, last=time.perf_counter(), t0=time.perf_counter())
        note(f"F12 {structure}")
        state["started"] = time.perf_counter()
        blender_window.start_f12()

    def wait():
        main_loop_ran()  # the last gap too: from the last tick to the render's end
        if bpy.app.is_job_running('RENDER'):
            return False
        beat["on"] = False
        from raylab.blender.render_stats import LAST_RENDER
        scene = bpy.context.window_manager.windows[0].scene
        report["stalls"][key or structure] = dict(longest_s=round(beat["longest"], 3),
                                           render_s=round(time.perf_counter() - state["started"], 3),
                                           ticks=beat["ticks"], finished=LAST_RENDER in scene)
        print(f"raylab F12 {LEVEL} {key or structure}: longest main-loop stall {beat['longest']:.3f} s "
              f"in a render of {time.perf_counter() - state['started']:.2f} s", flush=True)
        for window in list(bpy.context.window_manager.windows)[1:]:  # close the render window
            window_close(window)

    return [start, wait]


def window_close(window):
    area = window.screen.areas[0]
    with bpy.context.temp_override(window=window, area=area):
        bpy.ops.render.view_cancel()


def set_up():
    import raylab
    raylab.register()
    if TRACE:
        from raylab.blender import render_engine
        for name in ("export_scene", "render_exported", "_store_last_render"):
            traced(render_engine, name)
        traced(render_engine.RaylabRenderEngine, "_write_result")
        render = render_engine.RaylabRenderEngine.render

        def traced_render(self, depsgraph):  # Blender counts the parameters
            note("render starts")
            try:
                return render(self, depsgraph)
            finally:
                note("render ends")
        render_engine.RaylabRenderEngine.render = traced_render
        bpy.app.handlers.render_pre.append(lambda *_: note("render_pre"))
        import threading

        def watch_interpreter():  # a thread that only wants the interpreter lock: when it waits, someone holds it
            last = time.perf_counter()
            while True:
                time.sleep(0.01)
                now = time.perf_counter()
                if beat["on"] and now - last > 0.3:
                    note(f"a Python thread waited {now - last:.3f} s for the interpreter from {last - beat['t0']:.3f}")
                last = now
        threading.Thread(target=watch_interpreter, daemon=True).start()
        bpy.app.handlers.render_post.append(lambda *_: note("render_post"))


STRUCTURES = session.ARGS[2].split(",") if len(session.ARGS) > 2 else None


# The engine's own Python (the scene's export, the result's passes) runs on the job thread while Blender's
# main loop needs the interpreter for every timer and panel: for one more render, the export first runs
# Python without a break until a main-thread timer has ticked meanwhile, or PYTHON_LIMIT_SECONDS passed.
# Before issue 40 the job thread kept the interpreter for 10 s at a time (the guard's switch interval held
# through the whole render): no tick came.
PYTHON_LIMIT_SECONDS = 8.0


def busy_export(structure):
    def patch():
        from raylab.blender import render_engine
        export = render_engine.export_scene
        stretch = report["python_stretch"] = {"structure": structure}

        def export_after_python(depsgraph):
            ticks = beat["ticks"]
            started = time.perf_counter()
            while beat["ticks"] == ticks and time.perf_counter() - started < PYTHON_LIMIT_SECONDS:
                sum(range(1000))  # Python without a break: no call that lets go of the interpreter
            stretch.update(seconds=round(time.perf_counter() - started, 3),
                           main_thread_ticked=beat["ticks"] > ticks)
            render_engine.export_scene = export
            return export(depsgraph)
        render_engine.export_scene = export_after_python
    return [patch, *render_with(structure, f"{structure}, its export running Python")]


def steps():
    from raylab import api
    out = [open_level]
    # The structures a level's viewport offers (all but "none"): in a level F12 renders with that one.
    for structure in STRUCTURES or [name for name in api.STRUCTURE_INFO if name != "none"]:
        out += render_with(structure)
    return out + busy_export("bvh")


set_up()
SESSION.run(steps(), first_interval=1.0, interval=0.5, wait=0.1, watchdog_seconds=240)
