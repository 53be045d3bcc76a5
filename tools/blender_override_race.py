"""Blender running on Python 3.11 or older crashes when a script calls an operator inside a context
override while another Python thread runs; no add-on is needed. Blender looks context members up in the
override's dict without taking the interpreter lock when Python says a thread state is current, and
Python 3.11 keeps one global "current" state: the other thread's. Python 3.12 made it per thread. So
Debian 12's Blender 3.4 (Python 3.11) crashes and Debian 13's Blender 4.3 (Python 3.13) does not; the
official builds of Blender 4.2 to 4.5 bundle Python 3.11 and should behave as 3.4 does (not tried here).

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup FILE.blend \
        --python tools/blender_override_race.py -- MODE REPORT.json

MODE: `override` (a spinning Python thread and select_all inside temp_override: Blender 3.4 on Debian 12
segfaults within seconds), `nothread` (the same calls, no thread: 5,000 calls pass), or `plain` (the
thread, and the calls in the timer's own context: they pass). REPORT.json gets the number of calls
once they are done; a crash writes nothing. This is why raylab's Compare Structures starts its worker
after its operator returned, and why the GUI tests start F12 and call operators during a job without
an override (ARCHITECTURE.md, "Blender's threads").
"""
import json
import sys
import threading

import bpy

MODE, REPORT = sys.argv[sys.argv.index("--") + 1:][:2]
CALLS = 5000
calls = 0
stop = threading.Event()


def spin():
    """Pure Python that allocates, as any worker thread between its native calls."""
    items = []
    while not stop.is_set():
        items.append({"a": [1, 2, 3]})
        if len(items) > 1000:
            items = []


def main_window_override():
    window = bpy.context.window_manager.windows[0]
    area = max(window.screen.areas, key=lambda a: a.width * a.height)
    return dict(window=window, area=area, region=next(r for r in area.regions if r.type == 'WINDOW'))


def step():
    global calls
    for _ in range(50):
        if MODE == "plain":
            bpy.ops.object.select_all(action='TOGGLE')
        else:
            with bpy.context.temp_override(**main_window_override()):
                bpy.ops.object.select_all(action='TOGGLE')
        calls += 1
    if calls < CALLS:
        return 0.01
    stop.set()
    with open(REPORT, "w") as file:
        json.dump({"mode": MODE, "calls": calls, "blender": bpy.app.version_string, "python": sys.version}, file)
    bpy.ops.wm.quit_blender()
    return None


if MODE not in ("override", "nothread", "plain"):
    raise SystemExit(f"unknown mode {MODE!r}: override, nothread or plain")
if MODE != "nothread":
    threading.Thread(target=spin, daemon=True).start()
bpy.app.timers.register(step, first_interval=1.0)
