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
# bpy.ops.render.render() from a script does, stores it at once). The job thread never writes an ID.
_pending_records = {}  # scene name -> record


def _store_last_render(scene_name, record):
    if threading.current_thread() is threading.main_thread():
        bpy.data.scenes[scene_name][render_stats.LAST_RENDER] = record
    else:
        _pending_records[scene_name] = record


# F12 calls update_render_passes() and render() on a job thread. Blender (3.4 to 5.2) keeps "may Python
# write blend data" in one global flag, which each call into a Python class method saves, sets and
# restores, on any thread. If the job thread enters an engine method while the main thread is half-way
# through a panel's or header's draw (the flag then says "no writes"), it saves "no writes" and puts it
# back when it returns, after the main thread has restored "writes": from then on every bpy.ops call
# fails with "can't modify blend data in this state (drawing/rendering)", every ID write (the record's
# below) with "Writing to ID classes in this context is not allowed", and Blender cannot quit (issues 12
# and 40). The job thread takes the interpreter in the middle of a draw in two ways: Python hands it over
# after sys.getswitchinterval() (5 ms), and a draw lets go of it (a file read, numpy on a large array, a
# native call that releases it: any add-on's draw may; tests/gui/render_repeat.py forces both).
# So the job thread enters and leaves the engine only while the main thread is parked in a timer, which
# runs between events, never inside a draw:
#  1. render_pre (job thread) raises the switch interval to 10 s (a pure-Python draw that starts now is
#     not interrupted), asks the main thread to park and waits until it does; the main thread's timer
#     (_flush_last_renders) then waits, letting go of the interpreter, until render() has begun (or the
#     render ended, or _PARK_SECONDS passed). Blender calls update_render_passes() and render() meanwhile.
#  2. render() puts Python's own interval back as it begins: the engine's export and numpy never hold the
#     main loop for long (with 10 s throughout, the main thread waited for the interpreter whenever
#     the job thread took it back first, and F12 held the main loop: docs/bench/history.md).
#  3. When render() ends, it raises the interval and parks the main thread again before it returns, for
#     what Blender does after it (another view layer's render(), the compositor's update_render_passes());
#     render_post (job thread) lets the main thread go, and the timer ends the guard once the job is over.
# Each wait has a limit (a main thread that waits for the render job itself runs no timer), so the guard
# can delay a render or hold the main loop for _PARK_SECONDS, never hang either.
_SWITCH_INTERVAL_WHILE_RENDERING = 10.0
_TIMER_SECONDS = 0.05  # the timer's period: how long the job thread waits for the main thread, on average half
_MAIN_THREAD_WAIT_SECONDS = 2.0  # the longest the job thread waits for the main thread to park
_PARK_SECONDS = 0.3  # the longest the main thread stays parked (Blender's own work before render(), after it)
_guard_lock = threading.Lock()
_saved_switch_interval = []  # the interval to restore, while a render holds the guard
_park_requested = threading.Event()  # the job thread is about to enter or leave the engine
_main_parked = threading.Event()  # the main thread is parked in the timer, outside any draw
_park_over = threading.Event()  # render() has begun, or the render's engine calls are over


def _on_job_thread():
    return threading.current_thread() is not threading.main_thread()


def _take_guard():
    """On the job thread: the long switch interval, then the main thread parked (or the wait's limit)."""
    with _guard_lock:
        if not _saved_switch_interval:
            _saved_switch_interval.append(sys.getswitchinterval())
            sys.setswitchinterval(_SWITCH_INTERVAL_WHILE_RENDERING)
        _park_over.clear()
        _main_parked.clear()
        _park_requested.set()
    _main_parked.wait(_MAIN_THREAD_WAIT_SECONDS)  # lets go of the interpreter meanwhile


def _park_main_thread():
    """On the main thread, in the timer: if the job thread asks, waits (not holding the interpreter) until
    render() has begun or the render's engine calls are over, for _PARK_SECONDS at most."""
    if not _park_requested.is_set():
        return
    _park_requested.clear()
    _main_parked.set()
    _park_over.wait(_PARK_SECONDS)


def _flush_last_renders():
    _park_main_thread()
    with _guard_lock:
        if _saved_switch_interval and not bpy.app.is_job_running('RENDER'):
            _release_render_guard()  # the job is over: its thread calls no more Python
    while _pending_records:
        name, record = _pending_records.popitem()
        scene = bpy.data.scenes.get(name)
        if scene is None:
            continue
        try:
            scene[render_stats.LAST_RENDER] = record
        except AttributeError:
            # Writes refused (a draw somewhere left Blender's flag at "no writes"): kept for the next tick,
            # and the timer lives on; an exception would unregister it, and the guard with it.
            _pending_records.setdefault(name, record)
            break
    return _TIMER_SECONDS


@bpy.app.handlers.persistent
def _guard_render_start(scene, *_args):
    """render_pre: takes the guard and parks the main thread before Blender calls the engine (step 1)."""
    if not _on_job_thread() or scene is None or scene.render.engine != RaylabRenderEngine.bl_idname:
        return
    _take_guard()


@bpy.app.handlers.persistent
def _guard_render_end(scene, *_args):
    """render_post and render_cancel: the engine's calls are over, the parked main thread may go on."""
    if _on_job_thread():
        _park_over.set()


def _entering_render():
    if _on_job_thread():
        with _guard_lock:  # here, not by the main thread: it needs the interpreter this thread now holds
            _release_render_guard()
        _park_over.set()  # the main thread was parked while Blender called render(): it may go on


def _leaving_render():
    if _on_job_thread():
        _take_guard()  # step 3: render() returns while the main thread is parked


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
        _entering_render()
        try:
            self._render(depsgraph)
        finally:
            _leaving_render()

    def _render(self, depsgraph):
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


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def register():
    _register_classes()
    for panel in _shared_panels():
        panel.COMPAT_ENGINES.add('RAYLAB')
    bpy.app.timers.register(_flush_last_renders, persistent=True)
    bpy.app.handlers.render_pre.append(_guard_render_start)
    bpy.app.handlers.render_post.append(_guard_render_end)
    bpy.app.handlers.render_cancel.append(_guard_render_end)


def unregister():
    if bpy.app.timers.is_registered(_flush_last_renders):
        bpy.app.timers.unregister(_flush_last_renders)
    _pending_records.clear()
    if _guard_render_start in bpy.app.handlers.render_pre:
        bpy.app.handlers.render_pre.remove(_guard_render_start)
    for handlers in (bpy.app.handlers.render_post, bpy.app.handlers.render_cancel):
        if _guard_render_end in handlers:
            handlers.remove(_guard_render_end)
    _release_render_guard()
    for panel in _shared_panels():
        panel.COMPAT_ENGINES.discard('RAYLAB')
    _unregister_classes()
