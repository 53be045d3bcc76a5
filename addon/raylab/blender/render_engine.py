"""The raylab render engine (F12 with Render Engine: raylab) and its Render Properties panels."""
import sys
import threading

import bpy

from .. import api
from . import build_settings, compat, cost_passes, levels, render_stats, text_fit, viewport_panels
from .scene_export import build_scene, export_scene, render_settings


def structure_settings(scene):
    """Where F12 takes its structure, depth and leaf size from: in a level, the viewport's Structure panel, so
    what the student sees is what F12 measures (one setting); elsewhere Render Properties' own."""
    return scene.raylab if levels.state(scene) is not None else scene.raylab_render


def render_exported(exported, props, structure=None, super_sampling=None, progress=None,
                    cost_rays=api.COST_RAYS[0], build=None):
    """Build the export with `structure` (default: the one of `build`, the settings group the structure's
    settings come from, by default `props`) and render it with `props`; returns raylab's result.
    cost_rays: which rays the result's per-pixel cost counts (api.COST_RAYS).

    Raises ExportError, ValueError (bad geometry or settings) or raylab.BuildError (memory budget)."""
    build = build or props
    scene, _ = build_scene(exported, **build_settings.build_kwargs(build, structure))
    return api.render(scene, exported.camera, exported.lights, exported.materials,
                      render_settings(exported, props, super_sampling, cost_rays), progress=progress)


# F12 renders in a job thread, while the main thread draws panels that read the scene's ID properties:
# the render's record waits here and a main-thread timer stores it (a render run on the main thread, as
# bpy.ops.render.render() from a script does, stores it at once).
_pending_records = {}  # scene name -> record


def _store_last_render(scene_name, record):
    if threading.current_thread() is threading.main_thread():
        bpy.data.scenes[scene_name][render_stats.LAST_RENDER] = record
    else:
        _pending_records[scene_name] = record


def _flush_last_renders():
    _main_thread_between_calls.set()  # a timer never runs inside a draw: see _guard_render_start
    if _saved_switch_interval and not bpy.app.is_job_running('RENDER'):
        _release_render_guard()  # the render job is over: its thread calls no more Python
    while _pending_records:
        name, record = _pending_records.popitem()
        scene = bpy.data.scenes.get(name)
        if scene is not None:
            scene[render_stats.LAST_RENDER] = record
    return _TIMER_SECONDS


# F12 calls render() on a job thread. Blender (3.4 to 4.3 at least) keeps "may Python write blend data"
# in one global flag, which each call into a Python class method saves, sets and restores. If the job
# thread enters update_render_passes() or render() while the main thread is half-way through drawing a
# panel or header in Python (the flag then says "no writes"), it saves "no writes" and puts it back when
# it returns, after the main thread has restored "writes": from then on every bpy.ops call fails with
# "can't modify blend data in this state (drawing/rendering)" and Blender cannot quit.
# Python lets a waiting thread take the interpreter from a running one after sys.getswitchinterval()
# (5 ms), so the job thread can take it in the middle of any draw longer than that, and it does so for
# render_init and render_pre themselves (seen in tests/gui/render_repeat.py's trace, 6 ms into a 30 ms
# header draw). So render_pre, on the job thread, before Blender calls the engine:
#  1. makes a waiting thread wait 10 s instead, until the render job has ended, so that no draw that
#     starts from now on can be interrupted (a draw of 10 s is beyond any panel; only a thread that wants
#     the interpreter while another runs Python without a break, the render's scene export, waits);
#  2. then waits until a main-thread timer has run. Timers run between events, never inside a draw, so
#     a draw that the job thread interrupted to run render_pre has finished by then and restored the
#     flag. Without this second step, Blender 4.3 still locked in 1 of 5 runs of 50 renders: after
#     render_pre the job thread took the interpreter back before the main thread could finish its draw.
# A forced race (render_repeat.py with 30 ms header draws) locked Blender at the 2nd render without
# either step. The wait ends after _MAIN_THREAD_WAIT_SECONDS in any case (a main thread blocked on the
# render job itself runs no timer and no draw), so it can delay a render but never hang one.
_SWITCH_INTERVAL_WHILE_RENDERING = 10.0
_TIMER_SECONDS = 0.1  # also the longest an F12 waits for the main thread (step 2), 50 ms on average
_MAIN_THREAD_WAIT_SECONDS = 2.0
_saved_switch_interval = []  # the interval to restore, while a render holds the guard
_main_thread_between_calls = threading.Event()


@bpy.app.handlers.persistent
def _guard_render_start(scene, *_args):
    """render_pre: takes the guard (released by _flush_last_renders once the job has ended rather than at
    render_post, which the job thread runs before it is done) and waits for the main thread to be
    outside any draw."""
    if (threading.current_thread() is threading.main_thread() or scene is None
            or scene.render.engine != RaylabRenderEngine.bl_idname):
        return
    if not _saved_switch_interval:  # else the last render's guard is still held: its job ended just now
        _saved_switch_interval.append(sys.getswitchinterval())
        sys.setswitchinterval(_SWITCH_INTERVAL_WHILE_RENDERING)
    _main_thread_between_calls.clear()
    _main_thread_between_calls.wait(_MAIN_THREAD_WAIT_SECONDS)  # lets go of the interpreter meanwhile


def _release_render_guard():
    if _saved_switch_interval:
        sys.setswitchinterval(_saved_switch_interval.pop())


class RaylabRenderEngine(bpy.types.RenderEngine):
    bl_idname = "RAYLAB"
    bl_label = "raylab"
    bl_use_preview = False

    def update_render_passes(self, scene=None, renderlayer=None):
        cost_passes.register_passes(self, scene, renderlayer)

    def render(self, depsgraph):
        scene = depsgraph.scene
        props = scene.raylab_render
        build = structure_settings(scene)
        view_layer = depsgraph.view_layer
        passes = view_layer.raylab_passes
        self.update_stats("", f"raylab {build.structure}: exporting the scene")
        try:
            exported = export_scene(depsgraph)
            self.update_stats("", f"raylab {build.structure}: building and rendering")
            result = render_exported(exported, props, progress=self._progress, cost_rays=passes.cost_rays,
                                     build=build)
        except (ValueError, api.BuildError) as error:
            self.report({'ERROR'}, f"raylab: {error}")
            self.update_stats("", f"raylab: {error}")
            return
        self._write_result(result, view_layer)
        if result.cancelled:
            self.update_stats("", f"raylab {build.structure}: cancelled")
            return
        record = render_stats.record(result.stats, props.super_sampling)
        line = render_stats.line(result.stats)
        scale = cost_passes.heat_scale(passes, result)
        if scale is not None:  # stated with the image, so that two renders compare on one scale
            record[render_stats.HEAT_SCALE] = scale
            line += f" | heat: {scale}"
        _store_last_render(scene.original.name_full, record)
        # The info text is printed by background renders but cleared from the render window when the
        # render ends; the result's message (error_set) is what the window keeps showing after it.
        self.update_stats("", line)
        self.error_set(line)

    def _progress(self, fraction):
        self.update_progress(fraction)
        return self.test_break()

    def _write_result(self, result, view_layer):
        height, width = result.image.shape[:2]
        # This view layer's part of the render result: Combined and the cost passes it registered.
        cost_passes.add_passes(self, view_layer)
        blender_result = self.begin_result(0, 0, width, height, layer=view_layer.name)
        try:
            layer = blender_result.layers[0]
            # raylab's row 0 is the top of the picture; Blender's buffers start at the bottom row.
            compat.set_pass_pixels(layer.passes["Combined"], result.image[::-1])
            cost_passes.write_passes(layer, result, view_layer.raylab_passes)
        finally:
            self.end_result(blender_result)  # a result begun is always ended: Blender waits for it


class RaylabRenderPanel:
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "render"
    COMPAT_ENGINES = {'RAYLAB'}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class RAYLAB_PT_render_settings(RaylabRenderPanel, bpy.types.Panel):
    bl_label = "raylab"

    def draw(self, context):
        props = context.scene.raylab_render
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        build = structure_settings(context.scene)
        if build != props:
            text_fit.label(layout, context, f"In a level F12 renders with the 3D viewport's structure: "
                                            f"{build.structure} (the sidebar's Structure panel)", 'INFO')
        column = layout.column()
        column.active = build == props
        viewport_panels.draw_structure_settings(column, props)
        layout.separator()
        layout.prop(props, "super_sampling")
        layout.prop(props, "max_recursion")
        layout.prop(props, "shadows")
        layout.prop(props, "robust_offset")
        layout.prop(props, "shadow_terminator")
        layout.prop(props, "tile_size")
        layout.label(text="World colour: background and ambient", icon='WORLD')


class RAYLAB_PT_render_stats(RaylabRenderPanel, bpy.types.Panel):
    bl_label = "raylab Last Render"

    def draw(self, context):
        render_stats.draw_last(self.layout, context)


# Blender's own panels (format, output, lens, light, ...) that list BLENDER_RENDER, shown for raylab too.
def _compatible_panels():
    return [panel for panel in bpy.types.Panel.__subclasses__()
            if 'BLENDER_RENDER' in getattr(panel, "COMPAT_ENGINES", ())]


_EEVEE_PANELS_USED = ("EEVEE_MATERIAL_PT_surface", "EEVEE_MATERIAL_PT_context_material",
                      "EEVEE_WORLD_PT_surface", "DATA_PT_EEVEE_light")

CLASSES = (RaylabRenderEngine, RAYLAB_PT_render_settings, RAYLAB_PT_render_stats)


def _shared_panels():
    return _compatible_panels() + [getattr(bpy.types, name) for name in _EEVEE_PANELS_USED
                                   if hasattr(bpy.types, name)]


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    for panel in _shared_panels():
        panel.COMPAT_ENGINES.add('RAYLAB')
    bpy.app.timers.register(_flush_last_renders, persistent=True)
    bpy.app.handlers.render_pre.append(_guard_render_start)


def unregister():
    if bpy.app.timers.is_registered(_flush_last_renders):
        bpy.app.timers.unregister(_flush_last_renders)
    _pending_records.clear()
    if _guard_render_start in bpy.app.handlers.render_pre:
        bpy.app.handlers.render_pre.remove(_guard_render_start)
    _release_render_guard()
    for panel in _shared_panels():
        panel.COMPAT_ENGINES.discard('RAYLAB')
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
