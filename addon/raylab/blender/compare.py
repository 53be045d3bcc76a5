"""Render the active scene once per acceleration structure and compare what each costs and saves.

Compare Structures is a job, as Blender's own renders and bakes are: the scene is exported on the main
thread, then a worker thread builds and renders it with one structure after the other while a modal
operator polls it from a timer (progress in the cursor, the status bar and the panel; a report per
structure; Esc cancels). The worker never touches bpy: it gets plain arrays and dicts, the native core
releases the GIL while it builds and renders, and the results are written to the scene on the main
thread when the job ends. Before each render a small sample of its pixels is rendered: a structure whose
estimated time exceeds the Preferences' limit is skipped with a note instead of freezing for minutes.
"""
import math
import threading
from dataclasses import dataclass, field

import bpy

from .. import api

from . import preferences, properties, render_stats
from .level_panels import wrapped
from .scene_export import build_scene, export_scene, render_settings

COMPARISON = "raylab_comparison"   # scene ID property: {structure: render_stats.record}
SKIPPED = "raylab_comparison_skipped"  # scene ID property: {structure: why it was not rendered}

SAMPLE_PIXELS = 256     # pixels of the sample render that estimates a structure's time
SAMPLE_TILE_SIZE = 8    # the sample's tiles: small, so that it runs on every core as the render does
POLL_SECONDS = 0.1      # the modal operator's timer


def sample_camera(camera, pixels=SAMPLE_PIXELS):
    """The camera dict at a resolution of about `pixels` pixels (same view, same aspect; never larger
    than the camera's), and the ratio of the full image's pixels to the sample's."""
    scale = camera["resolution_percentage"] / 100.0
    width, height = camera["resolution_x"] * scale, camera["resolution_y"] * scale
    shrink = max(1.0, math.sqrt(width * height / pixels))
    small_width, small_height = max(1, round(width / shrink)), max(1, round(height / shrink))
    sample = dict(camera, resolution_x=small_width, resolution_y=small_height, resolution_percentage=100)
    return sample, (round(width) * round(height)) / (small_width * small_height)


@dataclass
class StructureResult:
    structure: str
    stats: dict = None      # the render's stats; None when skipped
    image: object = None    # the render's (H, W, 4) float32 image; None when skipped
    cost: dict = None       # the render's per-pixel counters (COUNTERS -> (H, W) float32); None when skipped
    estimate: float = None  # seconds the sample predicted (None: no time limit, no estimate)
    note: str = ""          # why it was skipped


@dataclass
class CompareJob:
    """One comparison: run() does it all on the calling thread; start() runs it on a worker thread,
    which the main thread watches through `fraction`, `current`, `results` and `done`, and stops with
    cancel(). Inputs are plain data (an ExportedScene, render settings, build parameters)."""
    exported: object
    settings: dict
    build: dict                       # max_depth, leaf_size
    structures: tuple = api.STRUCTURES
    time_limit: float = 0.0           # seconds; 0 = none
    results: list = field(default_factory=list)
    current: str = ""                 # the structure being built or rendered
    fraction: float = 0.0             # of the whole job, 0..1
    error: Exception = None
    cancelled: bool = False
    done: bool = False

    def __post_init__(self):
        self._cancel = threading.Event()
        self._thread = None

    def start(self):
        self._thread = threading.Thread(target=self.run, name="raylab compare", daemon=True)
        self._thread.start()

    @property
    def started(self):
        return self._thread is not None

    def cancel(self):
        self._cancel.set()

    def join(self, timeout=None):
        if self._thread is not None:
            self._thread.join(timeout)

    @property
    def alive(self):
        return self._thread is not None and self._thread.is_alive()

    def run(self):
        try:
            for index, structure in enumerate(self.structures):
                if self._cancel.is_set():
                    break
                self.current = structure
                self._run_one(index, structure)
        except Exception as error:  # noqa: BLE001  reported by the operator; the thread must end cleanly
            self.error = error
        finally:
            self.cancelled = self._cancel.is_set()
            self.done = True

    def _run_one(self, index, structure):
        share = 1.0 / len(self.structures)
        start = index * share

        def progress(fraction):
            self.fraction = start + share * fraction
            return self._cancel.is_set()

        scene, _ = build_scene(self.exported, structure=structure, **self.build)
        estimate = None
        if self.time_limit > 0.0:
            estimate = self._estimate(scene)
            if estimate is None:  # cancelled
                return
            if estimate > self.time_limit:
                self.results.append(StructureResult(structure, estimate=estimate, note=(
                    f"skipped: its render would take about {estimate:.3g} s, over the limit of "
                    f"{self.time_limit:.3g} s (raise it in the add-on's Preferences)")))
                return
        result = api.render(scene, self.exported.camera, self.exported.lights, self.exported.materials,
                            self.settings, progress=progress)
        if not result.cancelled:
            self.results.append(StructureResult(structure, stats=result.stats, image=result.image,
                                                cost=result.cost, estimate=estimate))

    def _estimate(self, scene):
        """Seconds the full render would take, from a render of about SAMPLE_PIXELS of its pixels;
        None when cancelled."""
        camera, ratio = sample_camera(self.exported.camera)
        sample = api.render(scene, camera, self.exported.lights, self.exported.materials,
                            dict(self.settings, tile_size=SAMPLE_TILE_SIZE),
                            progress=lambda _: self._cancel.is_set())
        return None if sample.cancelled else sample.stats["render_seconds"] * ratio

    def store(self, scene, super_sampling):
        """Writes the finished comparison on the scene (main thread only)."""
        scene[COMPARISON] = {r.structure: render_stats.record(r.stats, super_sampling)
                             for r in self.results if r.stats is not None}
        scene[SKIPPED] = {r.structure: r.note for r in self.results if r.stats is None}


def make_job(exported, props, super_sampling=None, structures=api.STRUCTURES, time_limit=0.0,
             cost_rays=api.COST_RAYS[0]):
    """The job for an export with the settings of scene.raylab_render (read now, on the main thread);
    cost_rays: which rays the results' per-pixel cost counts (api.COST_RAYS)."""
    return CompareJob(exported, render_settings(exported, props, super_sampling, cost_rays),
                      dict(max_depth=properties.depth_setting(props), leaf_size=props.leaf_size), tuple(structures), time_limit)


def compare_structures(exported, props, super_sampling=None, structures=api.STRUCTURES, time_limit=0.0):
    """Renders the export with every structure on this thread: [StructureResult], in order (the demo's
    way; no limit by default). Raises what a render raises."""
    job = make_job(exported, props, super_sampling, structures, time_limit)
    job.run()
    if job.error is not None:
        raise job.error
    return job.results


def new_job(context, time_limit=None):
    """The operator's job for the context's scene, exported now (main thread), with the Preferences'
    time limit unless given. Raises ExportError (a ValueError)."""
    limit = preferences.settings(context).compare_time_limit if time_limit is None else time_limit
    return make_job(export_scene(context.evaluated_depsgraph_get()), context.scene.raylab_render,
                    time_limit=limit)


def result_line(result):
    if result.stats is None:
        return f"raylab {result.structure}: {result.note}"
    return render_stats.line(result.stats)


_running = None  # the job the modal operator watches; the panel shows its progress


def running_job():
    return _running


# Why the worker starts late and is joined early: a Blender on Python 3.11 or older (Debian 12's 3.4, the
# official 4.2-4.5 builds) crashes within seconds, with no add-on at all (ARCHITECTURE.md, "Blender's
# threads"), when an operator called inside a context override looks the context up while another
# thread holds the interpreter: Blender then reads the override's dict without the lock, as Python 3.11
# reports the other thread's state as the current one. So the worker, which runs Python between its
# native calls, starts at the modal timer's first tick, once the operator a script may have called with
# an override has returned, and is joined before the results are stored (storing may call operators:
# the heat maps split an area).
class StructureJobOperator:
    """The operator side of a CompareJob, for every operator that renders once per structure (Compare
    Structures, the heat maps): execute() runs the job at once (scripts), invoke() on a worker thread
    watched by a modal timer (progress, a report per structure, Esc cancels). A subclass gives
    job_for(context, time_limit) (a staticmethod: the job, exported on the main thread), _finish(context,
    job) (main thread: store the results) and `activity`."""
    activity = "comparing structures"  # for the status bar: "raylab: <activity>, bvh (40%)"

    time_limit: bpy.props.FloatProperty(
        name="Time Limit", default=-1.0, min=-1.0, options={'SKIP_SAVE', 'HIDDEN'},
        description="Skip a structure whose render is estimated to take longer, in seconds (0: no limit; "
                    "-1: the limit in the add-on's Preferences)")

    def _new_job(self, context):
        return self.job_for(context, None if self.time_limit < 0.0 else self.time_limit)

    @classmethod
    def poll(cls, context):
        return _running is None

    def execute(self, context):
        """From a script: the whole comparison before returning (the time limit still applies)."""
        try:
            job = self._new_job(context)
        except ValueError as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        job.run()
        self._report_results(job.results)
        return self._done(context, job)

    def invoke(self, context, event):
        global _running
        try:
            job = self._new_job(context)
        except ValueError as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        # A name: an undo during the job replaces the scene's Python object.
        self._job, self._reported, self._scene = job, 0, context.scene.name
        wm = context.window_manager
        self._timer = wm.event_timer_add(POLL_SECONDS, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0.0, 1.0)
        _running = job
        self._show(context)
        return {'RUNNING_MODAL'}  # the worker starts at the first timer tick (see above the class)

    def modal(self, context, event):
        job = self._job
        if event.type == 'ESC' and event.value == 'PRESS' and not job.done:
            job.cancel()
            self.report({'INFO'}, f"raylab: cancelling ({self.activity})")
            return {'RUNNING_MODAL'}
        if event.type != 'TIMER':
            return {'PASS_THROUGH'}
        if not job.started:
            job.start()
            return {'PASS_THROUGH'}
        self._report_results(job.results[self._reported:])
        self._reported = len(job.results)
        if not job.done:
            self._show(context)
            return {'PASS_THROUGH'}
        job.join()  # its last Python lines too: _finish may call operators (see above the class)
        self._end(context)
        if job.cancelled:
            self.report({'INFO'}, f"raylab: cancelled ({self.activity}); the previous results are kept")
            return {'CANCELLED'}
        if context.scene.name != self._scene:
            self.report({'WARNING'}, f"raylab: the scene changed while {self.activity}; nothing stored")
            return {'CANCELLED'}
        return self._done(context, job)

    def _done(self, context, job):
        if job.error is not None:
            self.report({'ERROR'}, f"raylab: {job.error}")
            return {'CANCELLED'}
        return self._finish(context, job)

    def _report_results(self, results):
        for result in results:
            self.report({'WARNING'} if result.stats is None else {'INFO'}, result_line(result))

    def cancel(self, context):
        """Blender ends the operator (the window closes, a file is loaded): stop the worker too."""
        self._job.cancel()
        self._end(context)

    def _show(self, context):
        job = self._job
        context.window_manager.progress_update(job.fraction)
        if context.workspace is not None:
            context.workspace.status_text_set(
                f"raylab: {self.activity}, {job.current} ({100 * job.fraction:.0f}%), Esc to cancel")
        _tag_sidebar(context)

    def _end(self, context):
        global _running
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        _running = None
        _tag_sidebar(context)


class RAYLAB_OT_compare_structures(StructureJobOperator, bpy.types.Operator):
    """Render the scene with every acceleration structure and compare time, tests and memory"""
    bl_idname = "raylab.compare_structures"
    bl_label = "Compare Structures"
    bl_options = {'REGISTER', 'UNDO'}
    job_for = staticmethod(new_job)

    def _finish(self, context, job):
        job.store(context.scene, context.scene.raylab_render.super_sampling)
        rendered = [r for r in job.results if r.stats is not None]
        if not rendered:
            self.report({'WARNING'}, f"raylab: every structure was skipped ({len(job.results)})")
            return {'FINISHED'}
        fastest = min(rendered, key=lambda r: r.stats["render_seconds"]).structure
        skipped = len(job.results) - len(rendered)
        self.report({'INFO'}, f"raylab: compared {len(rendered)} structures"
                              + (f" ({skipped} skipped)" if skipped else "") + f"; fastest render: {fastest}")
        return {'FINISHED'}


def _tag_sidebar(context):
    for window in context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == 'VIEW_3D':
                for region in area.regions:
                    if region.type == 'UI':
                        region.tag_redraw()


def _progress_percent(_self):
    return 100.0 * _running.fraction if _running is not None else 0.0


class RAYLAB_PT_comparison(bpy.types.Panel):
    bl_label = "Structure Comparison"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "raylab"

    def draw(self, context):
        layout = self.layout
        scene = context.scene
        props = scene.raylab_render
        layout.prop(props, "super_sampling")
        prefs = preferences.settings(context)
        if isinstance(prefs, bpy.types.AddonPreferences):
            layout.prop(prefs, "compare_time_limit", text="Time Limit")
        if _running is not None:
            layout.prop(context.window_manager, "raylab_compare_progress", slider=True,
                        text=f"{_running.current}: Esc to cancel")
        else:
            layout.operator(RAYLAB_OT_compare_structures.bl_idname, icon='RENDER_STILL')
        table = scene.get(COMPARISON)
        for structure, note in (scene.get(SKIPPED) or {}).items():
            column = layout.column(align=True)
            for i, line in enumerate(wrapped(context, f"{structure} {note}", 4)):
                column.label(text=line, icon='ERROR' if i == 0 else 'BLANK1')
        if not table:
            return
        first = next(iter(table.values()))
        layout.label(text=render_stats.size_text(first))
        # The sidebar is narrow: one line of four values (a column per structure) under each measure.
        column = layout.column(align=True)
        header = column.grid_flow(row_major=True, columns=len(table), even_columns=True)
        for structure in table.keys():
            header.label(text=structure)
        for key, title, show in render_stats.FIELDS:
            column.separator()
            column.label(text=title)
            values = column.box().grid_flow(row_major=True, columns=len(table), even_columns=True)
            for row in table.values():
                values.label(text=show(row[key]))


CLASSES = (RAYLAB_OT_compare_structures, RAYLAB_PT_comparison)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    # Read-only (a getter only): the panel draws it as a progress bar.
    bpy.types.WindowManager.raylab_compare_progress = bpy.props.FloatProperty(
        name="Comparison Progress", subtype='PERCENTAGE', min=0.0, max=100.0, precision=0, get=_progress_percent,
        description="How much of Compare Structures is done")


def unregister():
    del bpy.types.WindowManager.raylab_compare_progress
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
