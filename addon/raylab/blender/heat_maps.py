"""Where does the work go: each structure's triangle tests per pixel, as heat maps side by side.

Render Heat Maps renders the scene once per structure (api.STRUCTURES) with the camera rays only, one ray
per pixel, at a small size (at most HEAT_MAP_PIXELS pixels, the camera's aspect), as a Compare Structures
job (compare.py: a worker thread, progress, Esc cancels, the Preferences' time limit). It makes one
picture, the Image "raylab heat maps": the maps side by side, left to right in api.STRUCTURES' order, on
ONE fixed scale, so that a colour is the same count in every map: 0 to the hardest pixel of them all, or
to scene.raylab_render.heat_maps_scale when set (brute force's every pixel is some 50 times the octree's
hardest: on its scale the octree's map is black, on a smaller one brute force's is all the last colour),
with the legend under them. Each map's numbers (its hardest pixel and where, the mean per pixel, the
total) go into scene["raylab_heat_maps"], written on the main thread, which the Image Editor writes under
each map (a draw callback, in the band left for them), the panels show and the levels' tasks read:

    {"counter", "label", "maximum", "size": [w, h] (the maps), "render_size": [W, H] (the probe's pixels),
     "structures": {name: {"hardest", "pixel": [x, y] (in the map), "probe_pixel": [x, y] (the same
                           place in the render's pixels, what the probe's Pixel X / Y take),
                           "mean", "total"}},
     "skipped": {name: why}}

Pixels count x from the left and y from the top, as the probe does.
"""
import dataclasses
import functools
import time

import bpy
import numpy as np

from .. import api
from . import compare, image_files, levels, preferences, text_fit
from .level_panels import TASK_SECTIONS
from .scene_export import export_scene

RECORD = "raylab_heat_maps"         # scene ID property (see the module docstring)
IMAGE_NAME = "raylab heat maps"     # the Image datablock the maps are shown in
COUNTER = "triangle_tests"          # the counter mapped (a COUNTERS name; its label from COST_PASS_INFO)
COST_RAYS = "primary"               # only the camera rays: each pixel is one ray (api.COST_RAYS)
HEAT_MAP_PIXELS = 160 * 120         # at most this many pixels per map: four renders stay quick on 2 cores
GAP = 6                             # background columns between two maps
GAP_COLOUR = (0.05, 0.05, 0.05, 1.0)
SPLIT = 0.45                        # the part of the 3D viewport the picture's Image Editor takes (< 0.5)
NUMBER_BAND = 52                    # picture rows under the maps where the Image Editor writes their numbers
NUMBER_LINES = 4                    # structure, hardest pixel and where, mean, total
TEXT_COLOR = (0.92, 0.92, 0.92, 1.0)


def counter_label(counter=COUNTER):
    """"Triangle tests": the label of the cost pass showing `counter`, else the counter's own name."""
    return next((p["label"] for p in api.COST_PASS_INFO.values() if p["counter"] == counter), counter)


def heat_map_camera(camera):
    """The camera dict the maps are rendered with: the scene camera at HEAT_MAP_PIXELS at most."""
    small, _ = compare.sample_camera(camera, HEAT_MAP_PIXELS)
    return small


def heat_record(results, render_size, scale=0):
    """The record of the module docstring from a finished job's StructureResults (plain data); its
    maximum is `scale`, or with 0 the hardest pixel of all the maps."""
    rendered = [r for r in results if r.cost is not None]
    structures = {}
    for result in rendered:
        counts = result.cost[COUNTER]
        height, width = counts.shape
        y, x = np.unravel_index(int(np.argmax(counts)), counts.shape)  # the first hardest, row by row
        structures[result.structure] = dict(
            hardest=int(counts[y, x]), pixel=[int(x), int(y)],
            # The map pixel's centre, in the render's pixels.
            probe_pixel=[int((x + 0.5) * render_size[0] / width), int((y + 0.5) * render_size[1] / height)],
            # A float: ID property integers are 32-bit, and brute force on a big mesh passes 2^31.
            mean=float(counts.mean()), total=float(counts.sum(dtype=np.float64)))
    size = list(rendered[0].cost[COUNTER].shape[::-1]) if rendered else [0, 0]
    return dict(counter=COUNTER, label=counter_label(), maximum=scale or scale_maximum(structures),
                size=size, render_size=list(render_size), structures=structures,
                skipped={r.structure: r.note for r in results if r.cost is None})


def scale_maximum(structures):
    """The one scale of every map: the hardest pixel of them all (at least 1: an empty scene has a scale)."""
    return max([1] + [s["hardest"] for s in structures.values()])


def colour(values, maximum):
    """The only call of the colour map (api.heat_map) and its legend (api.heat_legend)."""
    return api.heat_map(values, maximum), api.heat_legend(maximum, width=values.shape[1])


def heat_image(results, maximum):
    """The picture: every rendered structure's map side by side, GAP apart, and the legend under them.
    (H, W, 4) float32 linear RGBA, row 0 the top."""
    maps = [r.cost[COUNTER] for r in results if r.cost is not None]
    if not maps:
        raise ValueError("no structure was rendered: there is no heat map to show")
    height, width = maps[0].shape
    strip = np.zeros((height, len(maps) * width + (len(maps) - 1) * GAP), np.float32)
    for i, counts in enumerate(maps):
        strip[:, i * (width + GAP):i * (width + GAP) + width] = counts
    heat, legend = colour(strip, maximum)
    for i in range(1, len(maps)):
        heat[:, i * (width + GAP) - GAP:i * (width + GAP)] = GAP_COLOUR
    return np.concatenate([heat, np.broadcast_to(GAP_COLOUR, (NUMBER_BAND, heat.shape[1], 4)), legend])


def number_lines(name, numbers):
    """The lines written under a map."""
    return [name, "hardest {:,} at {}, {}".format(numbers["hardest"], *numbers["probe_pixel"]),
            f"mean {numbers['mean']:,.1f} per pixel", f"total {numbers['total']:,.0f}"]


def store_image(image_array):
    """Writes the picture into the Image IMAGE_NAME (made or resized as needed); returns the Image."""
    height, width = image_array.shape[:2]
    image = bpy.data.images.get(IMAGE_NAME)
    if image is not None and tuple(image.size) != (width, height):
        bpy.data.images.remove(image)
        image = None
    if image is None:
        image = bpy.data.images.new(IMAGE_NAME, width, height, alpha=True, float_buffer=True)
        image.colorspace_settings.name = image_files.linear_colorspace(image)
    image.pixels.foreach_set(np.ascontiguousarray(image_array[::-1], np.float32).ravel())  # rows go up
    image.update()
    return image


_split_areas = set()  # the Image Editors show_picture split off a 3D viewport (their as_pointer)


def close_picture(window):
    """Joins back the Image Editor show_picture split off, if it still shows the heat maps: leaving the level
    closes it (its numbers belong to the level's scene). An editor the user had or changed stays. Closed from
    a timer, once the level's operator is done: closing an area while the operator then removes the old
    scene crashed Blender 3.4."""
    for area in window.screen.areas:
        if area.as_pointer() in _split_areas and area.type == 'IMAGE_EDITOR' \
                and getattr(area.spaces.active.image, "name", None) == IMAGE_NAME:
            _split_areas.discard(area.as_pointer())
            deadline = time.monotonic() + 5.0
            bpy.app.timers.register(functools.partial(_close_area, area.as_pointer(), deadline), first_interval=0.0)


def _close_area(pointer, deadline):
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.as_pointer() == pointer and area.type == 'IMAGE_EDITOR':
                with bpy.context.temp_override(window=window, area=area):
                    bpy.ops.screen.area_close()
                return None
    # Not on any window's screen for now: on Blender 3.x the level switch may have taken the window to
    # another workspace for a moment (levels/scene.py, the top bar); its screen comes back.
    return 0.05 if time.monotonic() < deadline else None


def show_picture(context, image):
    """Shows the picture in the window's Image Editor (its numbers are written under the maps); without one,
    the top part of the largest 3D viewport becomes one, the probe in view under the maps. The top: closing
    it (close_picture) gives its room back to that viewport, its one neighbour along a whole edge (closing
    a bottom part gave it to the timeline). (render.view_show's window is sized for the render, 160 pixels
    wide here: too small for the maps.)"""
    window = context.window or context.window_manager.windows[0]
    screen = window.screen
    area = next((a for a in screen.areas if a.type == 'IMAGE_EDITOR'), None)
    if area is None:
        views = [a for a in screen.areas if a.type == 'VIEW_3D']
        if not views:
            return None
        view = max(views, key=lambda a: a.width * a.height)
        before = {a.as_pointer() for a in screen.areas}
        region = next(r for r in view.regions if r.type == 'WINDOW')
        # Blender puts the new area on top when the factor (the lower part's share) is over one half, and
        # gives it copies of the regions without the sidebar's tab: the new area becomes the editor, the
        # viewport keeps its own sidebar, on the tab the user had (the raylab tab, with the tasks). The
        # areas' places are only laid out at the next redraw: the new one is told by its pointer.
        with context.temp_override(window=window, area=view, region=region):
            bpy.ops.screen.area_split(direction='HORIZONTAL', factor=1.0 - SPLIT)
        area = next(a for a in screen.areas if a.as_pointer() not in before)
        area.type = 'IMAGE_EDITOR'
        _split_areas.add(area.as_pointer())
    area.spaces.active.image = image
    area.tag_redraw()
    return area


def new_job(context, time_limit=None):
    """The heat maps' CompareJob for the context's scene, exported now (main thread). Raises ExportError."""
    exported = export_scene(context.evaluated_depsgraph_get())
    camera = heat_map_camera(exported.camera)
    limit = preferences.settings(context).compare_time_limit if time_limit is None else time_limit
    job = compare.make_job(dataclasses.replace(exported, camera=camera), context.scene.raylab_render,
                           super_sampling=1, time_limit=limit, cost_rays=COST_RAYS)
    # The maps count camera rays only: shadow and reflection rays would be traced for nothing (a shadow
    # ray per lit pixel and light, each as dear as a camera ray under brute force).
    job.settings.update(shadows=False, max_recursion=0)
    job.render_size = api.image_size(exported.camera)  # the probe's pixels, for the record
    return job


def finish(context, job):
    """Main thread: stores the record and the picture of a finished job; returns the record."""
    record = heat_record(job.results, job.render_size, context.scene.raylab_render.heat_maps_scale)
    image = store_image(heat_image(job.results, record["maximum"]))
    context.scene[RECORD] = record
    if not bpy.app.background:  # no window to show it in
        show_picture(context, image)
    return record


class RAYLAB_OT_heat_maps(compare.StructureJobOperator, bpy.types.Operator):
    """Render the camera rays with every structure and show where each one's triangle tests go, on one scale"""
    bl_idname = "raylab.heat_maps"
    bl_label = "Render Heat Maps"
    bl_options = {'REGISTER', 'UNDO'}
    activity = "rendering heat maps"
    job_for = staticmethod(new_job)

    def _finish(self, context, job):
        try:
            record = finish(context, job)
        except ValueError as error:
            self.report({'WARNING'}, f"raylab: {error}")
            return {'CANCELLED'}
        parts = ", ".join(f"{name} {s['hardest']:,}" for name, s in record["structures"].items())
        self.report({'INFO'}, f"raylab: {record['label'].lower()} of the hardest pixel: {parts}")
        return {'FINISHED'}


def draw_numbers(layout, context):
    """The heat maps' numbers, a column per map in the picture's order (reads the record only)."""
    record = context.scene.get(RECORD)
    if record is None:
        return
    structures = record["structures"]
    box = layout.box()
    width, height = record["size"]
    text_fit.label(box, context, f"Heat maps, left to right ({width} x {height} pixels, 1 ray each)", 'IMAGE_DATA',
                   boxes=1)
    text_fit.label(box, context, "One scale: " + api.heat_scale_text(record["label"], record["maximum"]), boxes=1)
    # A line per map: a table of five columns does not fit the sidebar.
    for name, s in structures.items():
        text_fit.label(box, context, f"{name}: hardest {s['hardest']:,} at ({s['probe_pixel'][0]}, "
                                     f"{s['probe_pixel'][1]}), mean {s['mean']:.1f}, total {s['total']:,.0f}",
                       'DOT', boxes=1)
    for name, why in record["skipped"].items():
        text_fit.label(box, context, f"{name} {why}", 'ERROR', boxes=1)


class RAYLAB_PT_heat_maps(bpy.types.Panel):
    """The numbers beside the picture, in the Image Editor's sidebar."""
    bl_label = "Heat Maps"
    bl_space_type = 'IMAGE_EDITOR'
    bl_region_type = 'UI'
    bl_category = "raylab"

    @classmethod
    def poll(cls, context):
        return context.scene is not None and RECORD in context.scene

    def draw(self, context):
        draw_numbers(self.layout, context)
        self.layout.prop(context.scene.raylab_render, "heat_maps_scale")
        self.layout.operator(RAYLAB_OT_heat_maps.bl_idname, icon='RENDER_STILL')


def _draw_numbers_under_maps():
    """The Image Editor's draw callback: each map's numbers in the band under it, placed through the
    editor's view (any zoom or pan), sized to the band. Reads the record only."""
    import blf
    context = bpy.context
    space, scene = context.space_data, context.scene
    image = getattr(space, "image", None)
    record = scene.get(RECORD) if scene is not None else None
    if image is None or image.name != IMAGE_NAME or record is None or not record["structures"]:
        return
    image_width, image_height = image.size
    width, height = record["size"]
    if not image_height > height + NUMBER_BAND:
        return  # an older picture of another size
    view = context.region.view2d
    font = 0
    for i, (name, numbers) in enumerate(record["structures"].items()):
        u = i * (width + GAP) / image_width
        x, top = view.view_to_region(u, 1.0 - height / image_height, clip=False)
        _, bottom = view.view_to_region(u, 1.0 - (height + NUMBER_BAND) / image_height, clip=False)
        line = (top - bottom) / (NUMBER_LINES + 0.5)
        if line < 6:
            return  # zoomed out too far to read
        blf.size(font, round(min(line * 0.75, 14 * context.preferences.system.ui_scale)))
        blf.color(font, *TEXT_COLOR)
        for k, text in enumerate(number_lines(name, numbers)):
            blf.position(font, x + 2, top - (k + 1) * line, 0)
            blf.draw(font, text)


CLASSES = (RAYLAB_OT_heat_maps, RAYLAB_PT_heat_maps)
_handles = []


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def register():
    _register_classes()
    TASK_SECTIONS.append(draw_numbers)
    levels.LEAVING.append(close_picture)
    _handles.append(bpy.types.SpaceImageEditor.draw_handler_add(_draw_numbers_under_maps, (), 'WINDOW', 'POST_PIXEL'))


def unregister():
    for handle in _handles:
        bpy.types.SpaceImageEditor.draw_handler_remove(handle, 'WINDOW')
    _handles.clear()
    if draw_numbers in TASK_SECTIONS:
        TASK_SECTIONS.remove(draw_numbers)
    if close_picture in levels.LEAVING:
        levels.LEAVING.remove(close_picture)
    _unregister_classes()
