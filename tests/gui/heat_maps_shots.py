"""Runs inside a real Blender window (xvfb-run): opens the "Where does the work go?" level, presses
Render Heat Maps as a student does (the modal job, on its worker thread), waits for it, and takes a
screenshot of the window: the level's tasks with the numbers under them, and above the 3D viewport the
Image Editor with the heat maps and the numbers in its sidebar.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup START.blend --enable-event-simulate \
        --python tests/gui/heat_maps_shots.py -- OUT_DIR

OUT_DIR/heat_maps_picture.png (the picture as it is), OUT_DIR/heat_maps_window.png (the screenshot),
OUT_DIR/heat_maps_shots.json: the tasks' ticks, the record, and where each map lies in the
window (from the Image Editor's view, in window pixels, y from the bottom); or "error".
"""
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import click_raylab_tab, screenshot, show_sidebar, view3d  # noqa: E402

OUT_DIR = session.out_dir()
LEVEL = "where_work_goes"
WATCHDOG_SECONDS = 300
report = {}
SESSION = session.Session(os.path.join(OUT_DIR, "heat_maps_shots.json"), report)

import raylab  # noqa: E402
from raylab.blender import compare, heat_maps, levels  # noqa: E402


def picture_area():
    """The Image Editor showing the heat maps, and its window (the main one: the maps open under the
    3D viewport)."""
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == 'IMAGE_EDITOR' and area.spaces.active.image is not None \
                    and area.spaces.active.image.name == heat_maps.IMAGE_NAME:
                return window, area
    return None, None


def open_level():
    report["areas_before"] = areas_now()
    levels.open_level(bpy.context, LEVEL)
    show_sidebar()


def press_render_heat_maps():
    window, area, region, _ = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        assert bpy.ops.raylab.heat_maps('INVOKE_DEFAULT', time_limit=0.0) == {'RUNNING_MODAL'}


def wait_for_the_job():
    """Retried until the job has ended and stored its record (the modal operator does that)."""
    return compare.running_job() is None and heat_maps.RECORD in bpy.context.scene


def fit_the_picture():
    report["panels_before_maps"] = len(seen["panels"])
    window, area = picture_area()
    assert area is not None, "no Image Editor shows the heat maps"
    region = next(r for r in area.regions if r.type == 'WINDOW')
    area.spaces.active.show_gizmo = False  # the zoom and pan buttons would sit on the last map
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.image.view_all(fit_view=True)


def shoot():
    scene = bpy.context.scene
    window, area = picture_area()
    region = next(r for r in area.regions if r.type == 'WINDOW')
    image = area.spaces.active.image
    record = scene[heat_maps.RECORD].to_dict()
    image_width, image_height = image.size
    width, height = record["size"]
    maps, bands = [], []

    def rect(left, top_row, bottom_row):
        # The image's own coordinates (0..1, v up) to the window's pixels.
        x0, y0 = region.view2d.view_to_region(left / image_width, 1.0 - bottom_row / image_height, clip=False)
        x1, y1 = region.view2d.view_to_region((left + width) / image_width, 1.0 - top_row / image_height, clip=False)
        return dict(x0=region.x + x0, y0=region.y + y0, x1=region.x + x1, y1=region.y + y1)

    for i, _ in enumerate(record["structures"]):
        left = i * (width + heat_maps.GAP)
        maps.append(rect(left, 0, height))  # the maps are the picture's top rows
        bands.append(rect(left, height, height + heat_maps.NUMBER_BAND))  # their numbers under them
    report.update(record=record, maps=maps, bands=bands, window_height=window.height,
                  window=dict(x=window.x, y=window.y, width=window.width, height=window.height),
                  region=session.rect(region),
                  ticks=[done for _, done in levels.task_list(scene)])
    # The picture itself, as the README shows it.
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    raylab.write_image(os.path.join(OUT_DIR, "heat_maps_picture.png"),
                       pixels.reshape(image_height, image_width, 4)[::-1])
    screenshot(os.path.join(OUT_DIR, "heat_maps_window.png"), window=window)
    # The 3D viewport's sidebar as the maps left it: the panels it drew since (the tab it shows), its tab
    # where Blender says it (4.x, 5.x), its height against its viewport's.
    _, view, _, sidebar = view3d()
    report["sidebar_after_maps"] = dict(panels=seen["panels"][report["panels_before_maps"]:],
                                        category=getattr(sidebar, "active_panel_category", None),
                                        height=sidebar.height, area_height=view.height,
                                        shown=view.spaces.active.show_region_ui)


def areas_now():
    window = bpy.context.window_manager.windows[0]
    return sorted([a.type, a.width, a.height] for a in window.screen.areas)


def next_level():
    """The student moves on: the Image Editor the heat maps opened closes with the level."""
    report["areas_with_maps"] = areas_now()
    window, area, region, _ = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        assert bpy.ops.raylab.level_next() == {'FINISHED'}
    report["level_after_next"] = levels.state(bpy.context.window_manager.windows[0].scene)["id"]


def after_next():
    report["areas_after_next"] = areas_now()


seen = {}


def set_up():
    raylab.register()
    seen["panels"] = session.PanelDraws()


STEPS = [open_level, click_raylab_tab, press_render_heat_maps, wait_for_the_job, fit_the_picture, shoot,
         next_level, after_next]

# A wait (wait_for_the_job) is tried again a second later. Progress: a step done, or the job's fraction moving.
SESSION.run(STEPS, set_up, wait=1.0, watchdog_seconds=WATCHDOG_SECONDS, what="the shots",
            progress=lambda: (len(STEPS), getattr(compare.running_job(), "fraction", None)))
