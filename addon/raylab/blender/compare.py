"""Render the active scene once per acceleration structure and compare what each costs and saves.

Compare Structures is a job, as Blender's own renders and bakes are: the scene is exported on the main
thread, then a worker thread builds and renders it with one structure after the other while a modal
operator polls it from a timer (progress in the cursor, the status bar and the panel; a report per
structure; Esc cancels). The worker never touches bpy: it gets plain arrays and dicts, the native core
releases the GIL while it builds and renders, and the results are written to the scene on the main
thread when the job ends. Before each render a small sample of its pixels is rendered: a structure whose
estimated time exceeds the Preferences' limit is not rendered in full, instead of freezing for minutes; the
table shows the sample's numbers scaled to the full image, marked as estimates, with a note.
"""
import math
import threading
from dataclasses import dataclass, field

import bpy

from .. import api

from . import build_settings, preferences, render_stats, text_fit
from .scene_export import build_scene, export_scene, render_settings

COMPARISON = "raylab_comparison"   # scene ID property: {structure: render_stats.record} (estimated or not)
SKIPPED = "raylab_comparison_skipped"  # scene ID property: {structure: why it was not rendered in full}

SAMPLE_PIXELS = 256     # pixels of the sample render that estimates a structure's time and counts
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
    estimated: dict = None  # when skipped: the sample's stats scaled to the full image (render_stats.scaled_to_image)
    note: str = ""          # why it was skipped


@dataclass
class CompareJob:
    """One comparison: run() does it all on the calling thread; start() runs it on a worker thread,
    which the main thread watches through `fraction`, `current`, `results` and `done`, and stops with
    cancel(). Inputs are plain data (an ExportedScene, render settings, build parameters)."""
    exported: object
    settings: dict
    build: dict                       # structure -> its build_settings.build_kwargs
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

        scene, _ = build_scene(self.exported, **self.build[structure])
        estimate = None
        if self.time_limit > 0.0:
            estimated = self._estimate(scene)
            if estimated is None:  # cancelled
                return
            estimate = estimated["render_seconds"]
            if estimate > self.time_limit:
                self.results.append(StructureResult(structure, estimate=estimate, estimated=estimated, note=(
                    f"skipped: its full render would take about {render_stats.seconds_text(estimate)}, over "
                    f"the limit of {render_stats.seconds_text(self.time_limit)} (raise it in the add-on's "
                    "Preferences)")))
                return
        result = api.render(scene, self.exported.camera, self.exported.lights, self.exported.materials,
                            self.settings, progress=progress)
        if not result.cancelled:
            self.results.append(StructureResult(structure, stats=result.stats, image=result.image,
                                                cost=result.cost, estimate=estimate))

    def _estimate(self, scene):
        """The full render's stats as a render of about SAMPLE_PIXELS of its pixels estimates them
        (render_stats.scaled_to_image: its render_seconds the time the full render would take); None when
        cancelled."""
        camera, _ = sample_camera(self.exported.camera)
        sample = api.render(scene, camera, self.exported.lights, self.exported.materials,
                            dict(self.settings, tile_size=SAMPLE_TILE_SIZE),
                            progress=lambda _: self._cancel.is_set())
        if sample.cancelled:
            return None
        return render_stats.scaled_to_image(sample.stats, *api.image_size(self.exported.camera))

    def store(self, scene, super_sampling):
        """Writes the finished comparison on the scene (main thread only): a skipped structure's row is
        its estimate."""
        scene[COMPARISON] = {
            r.structure: render_stats.record(r.estimated if r.stats is None else r.stats, super_sampling)
            for r in self.results if r.stats is not None or r.estimated is not None}
        scene[SKIPPED] = {r.structure: r.note for r in self.results if r.stats is None}


def make_job(exported, props, super_sampling=None, structures=api.STRUCTURES, time_limit=0.0,
             cost_rays=api.COST_RAYS[0]):
    """The job for an export with the settings of scene.raylab_render (read now, on the main thread);
    cost_rays: which rays the results' per-pixel cost counts (api.COST_RAYS)."""
    return CompareJob(exported, render_settings(exported, props, super_sampling, cost_rays),
                      {s: build_settings.build_kwargs(props, s) for s in structures}, tuple(structures),
                      time_limit)


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
        skipped = len(job.results) - len(rendered)
        if not rendered:
            self.report({'WARNING'}, f"raylab: every structure was over the time limit ({skipped}): "
                                     "the table shows estimates from a sample")
            return {'FINISHED'}
        fastest = min(rendered, key=lambda r: r.stats["render_seconds"]).structure
        self.report({'INFO'}, f"raylab: compared {len(rendered)} structures"
                              + (f" ({skipped} over the time limit, estimated from a sample)" if skipped else "")
                              + f"; fastest render: {fastest}")
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


BOXES = 1  # the table's values sit in a box (text_fit's margins)


def table_layout(context, table, width=None):
    """How the table (scene[COMPARISON]) is drawn in a region `width` pixels wide (the current one's by
    default): (columns, sections), sections a (title, [(structure, text)]) per measure. With a column per
    structure (columns == len(table)) the names head the columns, as long as every name and value fits
    its column; else (columns == 2) each measure has a row per structure, its name beside its value (with
    two structures or fewer both give a text the same room, and the columns are drawn)."""
    by_title = {title: [] for _, title, _ in render_stats.FIELDS}
    for structure, row in table.items():
        for title, text in render_stats.rows(row):
            by_title[title].append((structure, text))
    sections = [(title, cells) for title, cells in by_title.items() if cells]
    columns = len(table)

    def fits(text, boxes):
        room = text_fit.available(context, boxes=boxes, columns=columns, width=width)
        return text_fit.measure(text, text_fit.font_pixels(context)) <= room

    if not (all(fits(name, 0) for name in table) and all(fits(text, BOXES) for _, cells in sections
                                                         for _, text in cells)):
        columns = 2
    return columns, sections


def draw_table(layout, context, table):
    """The comparison table, each text at its measured width (table_layout), then the estimates' footnote."""
    columns, sections = table_layout(context, table)
    column = layout.column(align=True)
    if columns == len(table):
        header = column.grid_flow(row_major=True, columns=columns, even_columns=True)
        for structure in table.keys():
            text_fit.label(header, context, structure, columns=columns)
    for title, cells in sections:
        column.separator()
        text_fit.label(column, context, title)
        box = column.box()
        if columns == len(table):
            values = box.grid_flow(row_major=True, columns=columns, even_columns=True)
            for _, text in cells:
                text_fit.label(values, context, text, boxes=BOXES, columns=columns)
            continue
        for structure, text in cells:
            split = box.split(factor=0.5)
            text_fit.label(split, context, structure, boxes=BOXES, columns=columns)
            text_fit.label(split, context, text, boxes=BOXES, columns=columns)
    estimated = [row for row in table.values() if render_stats.ESTIMATED_FROM in row]
    if estimated:
        text_fit.label(layout, context, render_stats.estimate_note(estimated[0]))


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
        if table:
            text_fit.label(layout, context, render_stats.size_text(next(iter(table.values()))))
            draw_table(layout, context, table)
        # Under the table, where its estimates are: why a structure was not rendered in full.
        for structure, note in (scene.get(SKIPPED) or {}).items():
            text_fit.label(layout, context, f"{structure} {note}", icon='ERROR')


CLASSES = (RAYLAB_OT_compare_structures, RAYLAB_PT_comparison)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def register():
    _register_classes()
    # Read-only (a getter only): the panel draws it as a progress bar.
    bpy.types.WindowManager.raylab_compare_progress = bpy.props.FloatProperty(
        name="Comparison Progress", subtype='PERCENTAGE', min=0.0, max=100.0, precision=0, get=_progress_percent,
        description="How much of Compare Structures is done")


def unregister():
    del bpy.types.WindowManager.raylab_compare_progress
    _unregister_classes()
