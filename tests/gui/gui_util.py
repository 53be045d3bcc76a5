"""Shared helpers of the GUI tests: start Blender in a real window under Xvfb with a script, and read
what it drew from its window screenshots.

Runs in the pytest process (/usr/bin/python3), never inside Blender.
"""
import json
import os
import re
import signal
import subprocess
import tempfile
import time

import numpy as np
from matplotlib.image import imread

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, os.pardir, os.pardir))
OUT = os.path.join(ROOT, "out", "gui")
SCREEN = "-screen 0 1600x900x24"


def start_blend(directory):
    """A saved default scene: opening a file keeps the splash screen out of the screenshots."""
    path = os.path.join(str(directory), "start.blend")
    subprocess.run(["blender", "-b", "--factory-startup", "--python-expr",
                    f"import bpy; bpy.ops.wm.save_as_mainfile(filepath={path!r})"],
                   check=True, capture_output=True, timeout=120)
    return path


def demo_blend(path):
    """Saves raylab's demo scene (save_demo_blend.py) to `path` afresh, for the F12 tests."""
    if os.path.exists(path):
        os.remove(path)
    subprocess.run(["blender", "-b", "--factory-startup", "--python-exit-code", "1",
                    "--python", os.path.join(HERE, "save_demo_blend.py"),
                    "--", path], check=True, capture_output=True, timeout=120)
    return path


HEARTBEAT = os.path.join(HERE, "heartbeat.py")
# How long a GUI Blender may go without a heartbeat (its main loop stopped: hung, or stuck in one long
# call) before it is stopped. A slow machine slows the beats' work, not the beats.
STALL_SECONDS = 180
# The first X display xvfb-run may take. Roots (chroots) have their own /tmp, where xvfb-run looks for free
# displays, but share the host's abstract X sockets: a root run beside a host run takes its own numbers.
FIRST_DISPLAY = {"debian13": 200, "sid": 300}.get(os.environ.get("RAYLAB_IN_ROOT", ""), 99)


def run_watched(command, timeout=None, env=None, check=False, **_):
    """subprocess.run for a Blender command line (under xvfb-run or not): heartbeat.py runs first in it,
    and the process is stopped only when no heartbeat came for STALL_SECONDS, never after a fixed time
    (`timeout`, what callers used to pass, is ignored). Output is captured as text."""
    if command[0] == "xvfb-run":
        command = [command[0], "-n", str(FIRST_DISPLAY), *command[1:]]
    index = command.index("blender") + 1
    command = command[:index] + ["--python", HEARTBEAT] + command[index:]
    with tempfile.TemporaryDirectory(prefix="raylab_gui_") as folder:
        beat = os.path.join(folder, "heartbeat")
        out_path, err_path = os.path.join(folder, "out"), os.path.join(folder, "err")
        with open(out_path, "w") as out, open(err_path, "w") as err:
            process = subprocess.Popen(command, stdout=out, stderr=err, start_new_session=True,
                                       env=dict(env or os.environ, RAYLAB_HEARTBEAT=beat))
            started = time.monotonic()
            while process.poll() is None:
                time.sleep(1.0)
                last = os.path.getmtime(beat) if os.path.exists(beat) else None
                quiet = time.time() - last if last is not None else time.monotonic() - started
                if quiet > STALL_SECONDS:
                    os.killpg(process.pid, signal.SIGKILL)
                    process.wait()
                    raise AssertionError(f"Blender gave no heartbeat for {STALL_SECONDS} s (hung): "
                                         f"{' '.join(command)}\n{open(out_path).read()[-2000:]}"
                                         f"{open(err_path).read()[-2000:]}")
        result = subprocess.CompletedProcess(command, process.returncode, open(out_path).read(),
                                             open(err_path).read())
    if check:
        result.check_returncode()
    return result


def run_gui_blender(script, args, blend=None, timeout=None, extra=(), screen=SCREEN):
    """Runs `script` inside Blender in a 1600x900 Xvfb window (or `screen`); the script quits Blender
    itself. `extra`: more Blender flags (e.g. --enable-event-simulate). Returns the finished process (its
    output helps when a report file is missing)."""
    command = ["xvfb-run", "-a", "-s", screen, "blender", "--factory-startup", *extra]
    command += [blend] if blend else []
    command += ["--python", script, "--", *args]
    return run_watched(command)


def run_session(script, report, blend, args=(), outputs=(), out=OUT, **options):
    """Runs tests/gui/`script` in a GUI Blender (run_gui_blender, `options` its own) on `blend` with `out`
    and `args` after `--`, once the report and the `outputs` (names in `out`) of a run before are
    removed; returns the report it wrote (read_report: none, or one with an "error", fails)."""
    os.makedirs(out, exist_ok=True)
    for name in (report, *outputs):
        if os.path.exists(os.path.join(out, name)):
            os.remove(os.path.join(out, name))
    process = run_gui_blender(os.path.join(HERE, script), [out, *args], blend, **options)
    return read_report(os.path.join(out, report), process)


def read_report(path, process=None):
    if not os.path.exists(path):
        tail = "" if process is None else (process.stdout[-2000:] + process.stderr[-2000:] + crash_report(process))
        raise AssertionError(f"Blender wrote no report {path}:\n{tail}")
    with open(path) as f:
        report = json.load(f)
    assert "error" not in report, report["error"]
    return report


def crash_report(process):
    """The crash report a crashed Blender wrote ("Writing: /tmp/NAME.crash.txt": the operators it ran and
    its backtrace), or "" if it wrote none: the clue to a crash seen once, which the log keeps."""
    match = re.search(r"^Writing: (\S+\.crash\.txt)$", process.stdout + process.stderr, re.MULTILINE)
    if match is None or not os.path.exists(match.group(1)):
        return ""
    with open(match.group(1), errors="replace") as f:
        return f"\n--- {match.group(1)}\n{f.read()[-4000:]}"


def load_rgb(path):
    return imread(path)[:, :, :3].astype(np.float32)


class Region:
    """A region's rectangle inside a window screenshot (Blender counts y from the window's bottom)."""

    def __init__(self, rect, window_height):
        self.x, self.y, self.width, self.height = rect["x"], rect["y"], rect["width"], rect["height"]
        self.window_height = window_height

    def crop(self, image):
        top = self.window_height - (self.y + self.height)
        return image[top:top + self.height, self.x:self.x + self.width]

    def row_col(self, x, y):
        """(row, column) in a cropped image of the region-space point (x, y)."""
        return self.height - 1 - int(round(y)), int(round(x))


def off_on_shots(script, name, blend, **options):
    """Runs a session that takes `name`_off.png and `name`_on.png of the same view (a drawing switched
    off, then on) and writes `name`.json with the view's "region": the report and both crops."""
    report = run_session(script, f"{name}.json", blend, outputs=(f"{name}_off.png", f"{name}_on.png"), **options)
    stem = os.path.join(OUT, name)
    off, on = load_rgb(stem + "_off.png"), load_rgb(stem + "_on.png")
    region = Region(report["region"], off.shape[0])
    return report, region.crop(off), region.crop(on)


def changed(before, after, threshold=0.03):
    """Pixels whose colour differs between two screenshots of the same view."""
    return np.abs(after - before).max(axis=-1) > threshold


def color_mask(image, color, tolerance=0.12):
    return np.all(np.abs(image - np.asarray(color[:3], dtype=np.float32)) < tolerance, axis=-1)


def dilate(mask, radius):
    out = mask.copy()
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            shifted = np.zeros_like(mask)
            ys = slice(max(dy, 0), mask.shape[0] + min(dy, 0))
            xs = slice(max(dx, 0), mask.shape[1] + min(dx, 0))
            yd = slice(max(-dy, 0), mask.shape[0] + min(-dy, 0))
            xd = slice(max(-dx, 0), mask.shape[1] + min(-dx, 0))
            shifted[ys, xs] = mask[yd, xd]
            out |= shifted
    return out


def segments_mask(region, segments, shape):
    """A mask of the 2D segments ((x0, y0), (x1, y1)) in region coordinates, drawn one pixel wide."""
    mask = np.zeros(shape, dtype=bool)
    for (x0, y0), (x1, y1) in segments:
        n = int(max(abs(x1 - x0), abs(y1 - y0))) * 2 + 2
        for t in np.linspace(0.0, 1.0, n):
            row, col = region.row_col(x0 + (x1 - x0) * t, y0 + (y1 - y0) * t)
            if 0 <= row < shape[0] and 0 <= col < shape[1]:
                mask[row, col] = True
    return mask
