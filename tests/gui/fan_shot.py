"""Runs inside a real Blender window (xvfb-run), on the demo scene (save_demo_blend.py): the probe from the
camera with its fan off, then with the largest fan (64 x 64 rays), seen from the side; two window
screenshots and a JSON with the viewport region's place and the fan's numbers.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup DEMO.blend --python tests/gui/fan_shot.py \
        -- OUT_DIR

Writes OUT_DIR/fan_off.png, fan_on.png and fan.json ("error" in it if anything failed).
RAYLAB_FAN_ALL_LINES=1 draws every ray of the fan as a line, as raylab did before issue 12: the picture
the test's threshold is checked against.
"""
import os
import sys

import bpy
from mathutils import Euler

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
import raylab  # noqa: E402
from blender_window import plain_view, screenshot, view3d  # noqa: E402
from raylab.blender import probe  # noqa: E402

STEM = os.path.join(session.out_dir(), "fan")
FAN_SIZE = 64
report = {}
SESSION = session.Session(STEM + ".json", report)


def set_up():
    raylab.register()
    if os.environ.get("RAYLAB_FAN_ALL_LINES"):
        probe.FAN_LINES_DRAWN = FAN_SIZE * FAN_SIZE
    settings = bpy.context.scene.raylab
    settings.show = False            # no boxes: the picture holds the mesh and the probe only
    settings.probe_source = 'CAMERA'
    settings.probe_enabled = True
    settings.fan_enabled = False
    settings.fan_size = FAN_SIZE
    # Close to the goat, from above and to the side of the camera (0, -11, 2.2): the fan runs over the goat.
    plain_view(Euler((1.25, 0.0, -0.5)), 7.0, location=(0.0, 0.0, 1.2))


def shot_fan_off():
    _, _, region, _ = view3d()
    report.update(region=session.rect(region))
    session.shoot_then_set(STEM + "_off.png", fan_enabled=True)


def shot_fan_on():
    screenshot(STEM + "_on.png")
    region = view3d()[2]
    report.update(fan_rays=FAN_SIZE * FAN_SIZE, lines_drawn=len(probe.fan_lines(FAN_SIZE)),
                  backdrop=list(probe.drawn_backdrops.get(region.as_pointer(), ())), text=probe.status_text(
                      bpy.context.scene),
                  status=probe.evaluate_probe(bpy.context.scene)["status"])


SESSION.run([shot_fan_off, shot_fan_on], set_up)
