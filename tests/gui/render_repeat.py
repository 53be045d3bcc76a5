"""In a real Blender window: F12 (render.render INVOKE_DEFAULT) with raylab many times in a row, started
from timers as a script or a user would, with operators and property edits while each render runs and
after it ends. Any operator error, a render that never ends, or Blender failing to quit is reported.

blender SCENE.blend --python render_repeat.py -- REPORT.json RENDERS

The F12 lock-up (issue 12): Blender's one "may Python write blend data" flag, saved and restored by every
Python class method call on any thread, stayed off after a render whose job thread entered render()
while the main thread was inside a Python draw; then every bpy.ops call fails with "can't modify blend
data in this state (drawing/rendering)". RAYLAB_SLOW_DRAW_MS=N adds N ms of pure-Python work to three
headers that redraw during a render, which makes that race likely: at 30 ms it locked Blender at the
2nd render without render_engine's guard.

The pokes while a render runs happen while raylab's engine is inside render(), at least once per
render, never while Blender builds, evaluates or frees the render's depsgraph on the job thread: an
edit then is Blender's own race, in its code around any engine's render() (every edit tags every
depsgraph of the file, the render's too, and nothing locks them; seen with raylab's engine only). CI met
it once on 4.3: Blender aborted on "Attempt to free nullptr pointer"; the core showed the job thread in
RE_engine_render freeing its depsgraph, on a node tree copy whose node runtime had a null vector
(ARCHITECTURE.md, "Blender's threads").
"""
import faulthandler
import json
import os
import sys
import threading
import time
import traceback

import bpy

faulthandler.enable(all_threads=True)  # if Blender aborts, every thread's Python stack goes to stderr

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "addon"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import blender_window  # noqa: E402
import raylab  # noqa: E402
from raylab.blender import render_engine  # noqa: E402

REPORT, RENDERS = os.path.abspath(sys.argv[sys.argv.index("--") + 1]), int(sys.argv[sys.argv.index("--") + 2])
RENDER_SECONDS_MAX = 120.0  # one small render takes well under a second; a stuck one never ends
report = {"renders_started": 0, "renders_finished": 0, "operator_calls": 0, "renders_poked_while_rendering": 0,
          "errors": []}
state = {"started_at": 0.0}
# Whether raylab's engine is inside render(): the job thread does not leave it while a poke runs
# (engine_lock), and waits there until one poke has run (poked_while_rendering), up to POKE_WAIT_SECONDS.
engine = {"inside_render": False}
engine_lock = threading.Lock()
poked_while_rendering = threading.Event()
POKE_WAIT_SECONDS = 5.0


def finish():
    report["finished"] = True
    with open(REPORT, "w") as file:
        json.dump(report, file, indent=2)
    try:
        bpy.ops.wm.quit_blender()
    except RuntimeError as error:  # the lock-up again: a Blender that cannot quit would hang the test
        report["errors"].append(f"quit: {error}")
        with open(REPORT, "w") as file:
            json.dump(report, file, indent=2)
        os._exit(2)


POKE = os.environ.get("RAYLAB_POKE", "ops,prop")  # what poke() does: operators, a property edit


def poke(when):
    """What a user or a script does meanwhile: operators and a property edit that undo can see."""
    if not POKE:
        return
    if NOTE_EVENTS:
        note(f"poke {when}")
    try:
        if "ops" in POKE:
            blender_window.call_in_main_window(bpy.ops.object.select_all, action='TOGGLE')
            blender_window.call_in_main_window(bpy.ops.object.select_all, action='TOGGLE')
        if "prop" in POKE:
            bpy.context.scene.raylab.fade = not bpy.context.scene.raylab.fade
        report["operator_calls"] += 1
    except Exception as error:  # the lock-up this test guards against: every bpy.ops call refused
        report["errors"].append(f"{when}, render {report['renders_started']}: {error}")


def start_render():
    try:
        blender_window.start_f12()
        report["renders_started"] += 1
        state["started_at"] = time.monotonic()
        return wait_for_render()
    except Exception:
        report["errors"].append(traceback.format_exc())
        finish()
        return None


def wait_for_render():
    """Timer: pokes while the render runs, then starts the next one (or finishes)."""
    try:
        if bpy.app.is_job_running('RENDER'):
            if time.monotonic() - state["started_at"] > RENDER_SECONDS_MAX:
                report["errors"].append(f"render {report['renders_started']} never ended")
                finish()
                return None
            if engine_lock.acquire(blocking=False):
                try:
                    if engine["inside_render"]:
                        poke("while rendering")
                        if not poked_while_rendering.is_set():
                            report["renders_poked_while_rendering"] += 1
                            poked_while_rendering.set()
                finally:
                    engine_lock.release()
            bpy.app.timers.register(wait_for_render, first_interval=0.05)
            return None
        report["renders_finished"] += 1
        poke("after the render")
        if report["errors"] and state.setdefault("retries", 0) < 20:
            state["retries"] += 1
            bpy.app.timers.register(retry, first_interval=0.5)
            return None
        if report["errors"] or report["renders_finished"] >= RENDERS:
            finish()
            return None
        bpy.app.timers.register(start_render, first_interval=0.05)
    except Exception:
        report["errors"].append(traceback.format_exc())
        finish()
    return None


def retry():
    errors = len(report["errors"])
    poke(f"retry {state['retries']}")
    report.setdefault("retries", []).append(len(report["errors"]) > errors)
    if len(report["errors"]) > errors and state["retries"] < 20:
        state["retries"] += 1
        return 0.5
    finish()
    return None


SLOW_DRAW_MS = float(os.environ.get("RAYLAB_SLOW_DRAW_MS", "0"))
NOTE_EVENTS = bool(os.environ.get("RAYLAB_NOTE_EVENTS"))


# RAYLAB_DRAW_RELEASES=1: the slow draws sleep instead, letting go of the interpreter lock as a draw that
# reads a file, runs numpy on a large array or calls native code that releases the lock does (any add-on's
# draw may): F12's job thread then takes the lock in the middle of a draw whatever the switch interval.
DRAW_RELEASES = bool(os.environ.get("RAYLAB_DRAW_RELEASES"))


def slow_draw(self, context):
    """A header that draws in pure Python for SLOW_DRAW_MS: Python may switch threads inside it (or, with
    DRAW_RELEASES, that sleeps for as long: it lets go of the interpreter lock)."""
    if NOTE_EVENTS:
        note(f"draw {type(self).__name__}")
    if DRAW_RELEASES:
        time.sleep(SLOW_DRAW_MS / 1000.0)
    end = time.perf_counter() + (0.0 if DRAW_RELEASES else SLOW_DRAW_MS / 1000.0)
    while time.perf_counter() < end:
        pass
    if NOTE_EVENTS:
        note(f"drawn {type(self).__name__}")


def note(event):
    """Which Python runs when, and on which thread: render_pre, render_post, the engine's methods."""
    import threading
    where = "main" if threading.current_thread() is threading.main_thread() else "job"
    report.setdefault("events", []).append(
        f"{1000 * time.perf_counter():.1f} ms {event} ({where}, render {report['renders_started']})")


def note_render_pre(*args):
    import threading
    report.setdefault("render_pre_threads", []).append(threading.current_thread() is threading.main_thread())
    note("render_pre")


def poked_inside(render):
    """The engine's render(), during which (and only then) the pokes of a running render happen."""
    def wrapper(self, depsgraph):
        with engine_lock:
            poked_while_rendering.clear()
            engine["inside_render"] = True
        try:
            return render(self, depsgraph)
        finally:
            poked_while_rendering.wait(POKE_WAIT_SECONDS)  # lets go of the interpreter meanwhile
            with engine_lock:  # a poke that runs now ends before Blender frees the render's depsgraph
                engine["inside_render"] = False
    wrapper.__name__ = render.__name__
    return wrapper


def noting(method):
    """The engine's `method`, noting its calls; the same parameters, which Blender counts."""
    if method.__name__ == "render":
        def wrapper(self, depsgraph):
            note("render")
            try:
                return method(self, depsgraph)
            finally:
                note("render returns")
    else:
        def wrapper(self, scene=None, renderlayer=None):
            note(method.__name__)
            try:
                return method(self, scene, renderlayer)
            finally:
                note(f"{method.__name__} returns")
    wrapper.__name__ = method.__name__
    return wrapper


# RAYLAB_SWITCH_INTERVAL=S: Python switches threads after S seconds instead of 5 ms (a tiny S makes the job
# thread take the lock from a draw whenever it waits for it; render_engine must lengthen it where that hurts).
if os.environ.get("RAYLAB_SWITCH_INTERVAL"):
    sys.setswitchinterval(float(os.environ["RAYLAB_SWITCH_INTERVAL"]))
raylab.register()
bpy.app.handlers.render_pre.append(note_render_pre)
bpy.app.handlers.render_post.append(lambda *args: note("render_post"))
if NOTE_EVENTS:
    bpy.app.handlers.render_init.append(lambda *args: note("render_init"))
    for name in ("render", "update_render_passes"):
        setattr(render_engine.RaylabRenderEngine, name, noting(getattr(render_engine.RaylabRenderEngine, name)))
render_engine.RaylabRenderEngine.render = poked_inside(render_engine.RaylabRenderEngine.render)
if os.environ.get("RAYLAB_NO_ERROR_SET"):  # to find whether RenderEngine.error_set plays a part in a crash
    render_engine.RaylabRenderEngine.error_set = lambda self, message: None
if SLOW_DRAW_MS:
    for header in (bpy.types.STATUSBAR_HT_header, bpy.types.IMAGE_HT_header, bpy.types.VIEW3D_HT_header):
        header.append(slow_draw)
bpy.context.preferences.view.render_display_type = 'WINDOW'
bpy.context.scene.render.resolution_percentage = 25
# To compare with Blender's own engines (e.g. BLENDER_WORKBENCH); their renders get no poke while they
# run (poked_inside wraps raylab's render()), so renders_poked_while_rendering stays 0.
if os.environ.get("RAYLAB_RENDER_ENGINE"):
    bpy.context.scene.render.engine = os.environ["RAYLAB_RENDER_ENGINE"]
bpy.app.timers.register(start_render, first_interval=1.0)
