"""Runs first in every GUI Blender (gui_util.run_watched adds it): touches $RAYLAB_HEARTBEAT once a second
from a timer, so the test waits as long as Blender's main loop runs, however slow the machine, and stops
only a Blender that stopped: no fixed wall-clock limit."""
import os

import bpy

PATH = os.environ.get("RAYLAB_HEARTBEAT")


def beat():
    with open(PATH, "a"):
        os.utime(PATH)
    return 1.0


if PATH:
    bpy.app.timers.register(beat, first_interval=0.0, persistent=True)
