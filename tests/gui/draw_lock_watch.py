"""Inside a GUI Blender: finds the Python draws (panels, headers, menus) that let go of Python's
interpreter lock in the middle of drawing, with the line that did it.

Why it matters: Blender keeps "may Python write blend data" in one global flag that every call into a
Python class method saves, sets and restores. If F12's job thread enters or leaves the render engine
while a draw on the main thread has let go of the lock (a file-system call, numpy on a large array, a
native call that releases it), the two save/restore pairs interleave and the flag stays at "no writes":
from then on every operator fails with "can't modify blend data in this state (drawing/rendering)"
(render_engine.py). So no raylab draw may let go of the lock, ever.

How: each draw method is wrapped to note that a draw is running; a watcher thread wakes every half
millisecond and, when it gets the lock while a draw is running, the main thread has let go of it
mid-draw: the watcher keeps the main thread's stack. The switch interval is raised so that Python never
takes the lock from the main thread by itself: only a draw that lets go of it is seen. Python 3.13 and
later hand the lock over readily (Debian 13's and sid's Blender); 3.11 seldom does, so there this finds
less.
"""
import sys
import threading
import time
import traceback

import bpy

SWITCH_INTERVAL = 30.0
_running = []  # the draws running on the main thread, innermost last
found = {}     # "Class.method | the line" -> the main thread's stack when it let go of the lock


def _wrap(cls, name):
    method = cls.__dict__.get(name)
    if method is None or getattr(method, "_watched", False):
        return

    # Blender passes as many arguments as the function's code names: (self, context), as the original.
    def watched(self, context):
        _running.append(f"{cls.__name__}.{name}")
        try:
            return method(self, context)
        finally:
            _running.pop()
    watched._watched = True
    setattr(cls, name, watched)


def _subclasses(base):
    found_classes, todo = [], [base]
    while todo:
        for sub in todo.pop().__subclasses__():
            found_classes.append(sub)
            todo.append(sub)
    return found_classes


def _wrap_all():
    for base, names in ((bpy.types.Panel, ("draw", "draw_header")), (bpy.types.Header, ("draw",)),
                        (bpy.types.Menu, ("draw",))):
        for cls in _subclasses(base):
            for name in names:
                _wrap(cls, name)
    return 1.0  # classes registered later (the add-on, a level's) are wrapped within a second


def _watch(main):
    while True:
        time.sleep(0.0005)
        if not _running:
            continue
        frame = sys._current_frames().get(main)
        if frame is None:
            continue
        stack = traceback.format_stack(frame)[-8:]
        line = stack[-1].strip().splitlines()[-1].strip() if stack else "?"
        found.setdefault(f"{_running[-1]} | {line}", "".join(stack))


def start():
    sys.setswitchinterval(SWITCH_INTERVAL)
    bpy.app.timers.register(_wrap_all, first_interval=0.0, persistent=True)
    threading.Thread(target=_watch, args=(threading.main_thread().ident,), daemon=True).start()
