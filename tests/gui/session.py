"""The frame of the GUI scripts that drive the checkout's raylab inside a real Blender window (xvfb-run):
the add-on on sys.path, the script's arguments, its report written as JSON when it ends (and Blender quit),
its steps run one timer tick apart, a watchdog. A script puts this folder on sys.path and imports it
before raylab:

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import session  # noqa: E402  (puts the checkout's add-on on sys.path)

    report = {}
    SESSION = session.Session(os.path.join(session.out_dir(), "name.json"), report)
    ...
    SESSION.run([step, step, ...], set_up=raylab.register)

A step returns None when it is done (the next one runs `interval` seconds later, so that the window
redraws in between), False to be called again `wait` seconds later (a wait), or a number of seconds to be
called again after (blender_window.step_timer). Should the script stop before it calls run() (an import
that fails), the report says so and Blender quits: no window is left open for the test to wait on.

blender_window.py holds the helpers that know no add-on (extension_session.py uses the installed one).
"""
import json
import os
import subprocess
import sys
import traceback

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, os.pardir, os.pardir))
sys.path.insert(0, os.path.join(ROOT, "addon"))

from blender_window import read_xwd, screenshot, step_timer, view3d, watch_progress  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def out_dir():
    """The first argument: the folder the script writes its pictures and its report into (made here)."""
    os.makedirs(ARGS[0], exist_ok=True)
    return ARGS[0]


def rect(region):
    """A region's rectangle in its window (y from the window's bottom), as the tests read it."""
    return dict(x=region.x, y=region.y, width=region.width, height=region.height)


def remove_meshes(scene):
    """Deletes the scene's mesh objects (the default cube): the script adds the meshes it draws."""
    for obj in list(scene.objects):
        if obj.type == 'MESH':
            bpy.data.objects.remove(obj)


def registered_scene_without_meshes():
    """raylab registered, and the window's scene with no mesh (remove_meshes): the script's set-up."""
    import raylab
    raylab.register()
    remove_meshes(bpy.context.scene)
    return bpy.context.scene


def shoot_then_set(path, **settings):
    """A window screenshot at `path`, then scene.raylab's `settings` changed and the 3D viewport told to
    redraw: what the next step's screenshot shows."""
    screenshot(path)
    for name, value in settings.items():
        setattr(bpy.context.scene.raylab, name, value)
    view3d().area.tag_redraw()


def sidebar_pixels():
    """The 3D viewport's sidebar as the X server shows it: (H, W, 3) floats, top row first."""
    window, _, _, sidebar = view3d()
    screen = read_xwd(subprocess.run(["xwd", "-root", "-silent"], capture_output=True, check=True).stdout)
    top = screen.shape[0] - (window.y + window.height) + (window.height - sidebar.y - sidebar.height)
    left = window.x + sidebar.x
    return screen[top:top + sidebar.height, left:left + sidebar.width].astype(np.float32) / 255.0


class PanelDraws(list):
    """The labels of raylab's 3D viewport sidebar panels, appended whenever Blender calls their draw: it
    draws the open panels of the tab shown, in the order they stand in the sidebar (a closed one draws its
    header alone). Made after raylab.register(); last_redraw() is the sidebar's latest redraw."""

    def __init__(self):
        super().__init__()
        for cls in bpy.types.Panel.__subclasses__():
            if cls.__module__.startswith("raylab.") and getattr(cls, "bl_space_type", "") == 'VIEW_3D':
                cls.draw = self._recording(cls.bl_label, cls.draw)

    def _recording(self, label, draw):
        # Exactly (self, context): Blender passes as many arguments as the function names (more crash it).
        def recorded(panel, context):
            self.append(label)
            draw(panel, context)
        return recorded

    def last_redraw(self, top="Levels"):
        """The panels drawn since the sidebar last drew its `top` panel ([] if it never did)."""
        return self[len(self) - 1 - self[::-1].index(top):] if top in self else []


def quit_blender():
    try:
        bpy.ops.wm.quit_blender()
    except RuntimeError:
        # A Blender stuck refusing every operator ("can't modify blend data in this state", the F12
        # lock-up render_engine.py describes) cannot quit: leave without it, the report is written.
        os._exit(1)


_made = []  # the script's Session, then "running" once its steps are started


def _never_ran():
    """Ends a script that stopped before it started its steps (an import failed, say): Blender quits,
    with the report saying so if the script made its Session; Blender's output has the traceback."""
    if "running" in _made:
        return None
    stopped = getattr(sys, "last_value", None)  # what stopped the script, once Python printed it
    why = "".join(traceback.format_exception(type(stopped), stopped, stopped.__traceback__)) if stopped else ""
    if _made:
        _made[0].error("the script stopped before it started its steps\n" + why)
        _made[0].finish()
    else:
        quit_blender()
    return None


bpy.app.timers.register(_never_ran, first_interval=0.5)


class Steps(list):
    """A list of steps that a decorator fills in the order the script defines them: @STEPS above a def."""

    def __call__(self, function):
        self.append(function)
        return function


class Session:
    """A script's run: `report` (a dict) written to `path` when the run ends, which quits Blender.

    What goes wrong goes into report["error"] (a traceback or the watchdog's words), or, with
    errors="errors", is appended to the list report["errors"] (the F12 scripts' reports)."""

    def __init__(self, path, report, indent=None, errors=None, finishing=None):
        self.path, self.report, self.indent, self.errors = path, report, indent, errors
        self.finishing = finishing  # called first when the run ends (to note its time, say)
        _made.append(self)

    def error(self, message):
        if self.errors:
            self.report.setdefault(self.errors, []).append(message)
        else:
            self.report["error"] = message

    def finish(self):
        if self.finishing is not None:
            self.finishing()
        with open(self.path, "w") as f:
            json.dump(self.report, f, indent=self.indent)
        quit_blender()

    def run(self, steps, set_up=None, first_interval=2.0, interval=1.5, wait=1.0, watchdog_seconds=None,
            progress=None, what="the session"):
        """set_up(), then the steps one per timer tick; with watchdog_seconds, the run ends with an error
        once progress() (by default the number of steps left) has not changed for that long."""
        _made.append("running")

        def watchdog():
            self.error(f"{what() if callable(what) else what} made no progress for {watchdog_seconds} s; steps left: "
                       f"{[getattr(s, '__name__', repr(s)) for s in steps]}")
            self.finish()

        try:
            if set_up is not None:
                set_up()
            bpy.app.timers.register(step_timer(steps, self.finish, self.report, interval, wait, self.error),
                                    first_interval=first_interval)
            if watchdog_seconds is not None:
                watch_progress(progress or (lambda: len(steps)), watchdog_seconds, watchdog)
        except Exception:
            self.error(traceback.format_exc())
            self.finish()


def wait_for_f12(settle_ticks, timeout_ticks=600, poll=0.25):
    """A step that waits for F12's render to end: its job done and the engine's statistics stored in the
    scene (render_stats.LAST_RENDER), then settle_ticks polls more, to let the render window draw the result.
    It fails after timeout_ticks polls."""
    from raylab.blender.render_stats import LAST_RENDER
    ticks = {"waited": 0, "after_done": 0}

    def rendered():
        ticks["waited"] += 1
        if ticks["waited"] > timeout_ticks:
            raise RuntimeError("timed out waiting for the render")
        if bpy.app.is_job_running('RENDER') or LAST_RENDER not in bpy.context.scene:
            return poll
        ticks["after_done"] += 1
        return poll if ticks["after_done"] < settle_ticks else None
    return rendered
