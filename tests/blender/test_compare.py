"""Compare Structures as a job: driven to its end on a worker thread it gives what rendering with each
structure one after the other gives; cancelled, it stops and stores nothing; a structure estimated to
take longer than the time limit is not rendered in full: the table shows its numbers estimated from a
sample (marked), with a note that says so, and every text of the table fits the default sidebar.

(The modal operator itself, its progress bar and Esc, need a window: tests/gui/test_compare_gui.py.)"""
import threading
import time

import bpy
import numpy as np
import pytest

import raylab
from raylab.blender import compare, default_scene, render_engine, render_stats, scene_export, text_fit

RESOLUTION = (96, 72)
COUNTS = ("rays", "rays_primary", "rays_shadow", "triangle_tests", "box_tests", "rays_ignored", "memory_bytes")


@pytest.fixture
def demo_scene():
    scene = bpy.context.scene
    default_scene.build_default_scene(scene, resolution=RESOLUTION)
    scene.render.engine = 'RAYLAB'
    scene.raylab_render.super_sampling = 1
    for key in (compare.COMPARISON, compare.SKIPPED):
        scene.pop(key, None)
    return scene


def drive(job, deadline=600.0):
    """What the modal operator's timer does: start the worker and poll until it is done (sleeping
    releases the GIL to the worker, as Blender's event loop does)."""
    job.start()
    fractions = []
    end = time.monotonic() + deadline
    while not job.done:
        assert time.monotonic() < end, "the job never ended"
        fractions.append(job.fraction)
        time.sleep(0.01)
    job.join()
    assert not job.alive
    assert fractions == sorted(fractions) and all(0.0 <= f <= 1.0 for f in fractions)
    return job


def test_the_job_gives_what_rendering_each_structure_in_turn_gives(demo_scene):
    job = drive(compare.new_job(bpy.context, time_limit=0.0))
    assert job.error is None and not job.cancelled
    assert [r.structure for r in job.results] == list(raylab.STRUCTURES)
    exported = scene_export.export_scene(bpy.context.evaluated_depsgraph_get())
    for result in job.results:
        alone = render_engine.render_exported(exported, demo_scene.raylab_render, structure=result.structure)
        assert {k: result.stats[k] for k in COUNTS} == {k: alone.stats[k] for k in COUNTS}, result.structure
        np.testing.assert_array_equal(result.image, alone.image)
    # Stored as the operator stores it: the table of the synchronous comparison, and no skip notes.
    job.store(demo_scene, demo_scene.raylab_render.super_sampling)
    table = demo_scene[compare.COMPARISON]
    assert list(table.keys()) == list(raylab.STRUCTURES)
    assert all(table[r.structure]["triangle_tests"] == r.stats["triangle_tests"] for r in job.results)
    assert dict(demo_scene[compare.SKIPPED]) == {}


def test_the_operator_from_a_script_runs_the_job_to_its_end(demo_scene):
    assert bpy.ops.raylab.compare_structures() == {'FINISHED'}
    assert list(demo_scene[compare.COMPARISON].keys()) == list(raylab.STRUCTURES)
    assert compare.running_job() is None


def test_cancel_stops_the_worker_and_stores_nothing(demo_scene):
    demo_scene.render.resolution_x, demo_scene.render.resolution_y = 640, 480  # long enough to cancel midway
    demo_scene[compare.COMPARISON] = {"kept": {"render_seconds": 1.0}}
    job = compare.new_job(bpy.context, time_limit=0.0)
    threads = threading.active_count()
    job.start()
    while job.fraction == 0.0 and not job.done:
        time.sleep(0.01)
    job.cancel()
    job.join(60.0)
    assert job.done and job.cancelled and not job.alive
    assert len(job.results) < len(raylab.STRUCTURES)
    assert threading.active_count() == threads, "the worker thread is gone"
    assert set(demo_scene[compare.COMPARISON].keys()) == {"kept"}, "a cancelled job writes nothing"
    assert compare.SKIPPED not in demo_scene


def test_a_structure_over_the_time_limit_is_estimated_from_a_sample_with_a_note(demo_scene):
    job = drive(compare.new_job(bpy.context, time_limit=1e-9))
    assert job.error is None
    assert [r.structure for r in job.results] == list(raylab.STRUCTURES)
    for result in job.results:
        assert result.stats is None and result.image is None and result.estimate > 0.0
        assert result.note.startswith("skipped") and "over the limit" in result.note
        assert "e+" not in result.note and "e-0" not in result.note.split("over the limit")[0], result.note
        assert result.structure in compare.result_line(result) and "skipped" in compare.result_line(result)
    job.store(demo_scene, 1)
    # The table still has every structure, brute force first, each row marked as an estimate.
    table = demo_scene[compare.COMPARISON]
    assert list(table.keys()) == list(raylab.STRUCTURES)
    assert all(row[render_stats.ESTIMATED_FROM] <= 1.5 * compare.SAMPLE_PIXELS for row in table.values())
    assert (table["none"]["width"], table["none"]["height"]) == RESOLUTION
    texts = dict(render_stats.rows(table["none"]))
    assert texts["Render"].startswith("~") and texts["Triangle tests"].startswith("~")
    assert not texts["Memory"].startswith("~") and not texts["Primary rays"].startswith("~")
    assert "estimated from a" in render_stats.estimate_note(table["none"])
    assert set(demo_scene[compare.SKIPPED].keys()) == set(raylab.STRUCTURES)


def test_the_estimate_is_the_full_render_scaled_down_to_its_sample(demo_scene):
    """Brute force's estimate against its full render: the same memory and primary rays (measured), and
    triangle tests and rays close to the full render's (scaled from the sample)."""
    job = compare.new_job(bpy.context, time_limit=1e-9)
    job.structures = ("none",)
    job.run()
    estimated = job.results[0].estimated
    exported = scene_export.export_scene(bpy.context.evaluated_depsgraph_get())
    full = render_engine.render_exported(exported, demo_scene.raylab_render, structure="none").stats
    assert (estimated["width"], estimated["height"]) == (full["width"], full["height"]) == RESOLUTION
    for key in ("memory_bytes", "rays_primary"):
        assert estimated[key] == full[key], key
    for key in ("rays", "rays_shadow", "triangle_tests"):
        assert estimated[key] == pytest.approx(full[key], rel=0.1), key


def test_every_text_of_the_table_fits_its_column_at_the_default_sidebar_width(demo_scene):
    """At Blender's default sidebar width (about 230 px) five columns leave no room, so each measure gets
    a row per structure, name beside value; a wide sidebar gets a column per structure. Either way every
    name and value fits the width it is drawn in (Blender would elide it), estimates included."""
    context = bpy.context
    pixels = text_fit.font_pixels(context)
    for time_limit in (0.0, 1e-9):  # measured, then estimated
        drive(compare.new_job(context, time_limit=time_limit)).store(demo_scene, 1)
        table = demo_scene[compare.COMPARISON]  # what the panel draws
        for width, columns in ((230, 2), (600, len(table))):
            layout_columns, sections = compare.table_layout(context, table, width=width)
            assert layout_columns == columns, width
            assert [title for title, _ in sections] == [title for _, title, _ in render_stats.FIELDS]
            room = text_fit.available(context, boxes=compare.BOXES, columns=columns, width=width)
            for title, cells in sections:
                assert [name for name, _ in cells] == list(raylab.STRUCTURES)
                for name, text in cells:
                    assert text_fit.measure(text, pixels) <= room, (width, title, text)
                    assert text_fit.measure(name, pixels) <= room, (width, name)
                    assert "e+" not in text and "e-" not in text, text


def test_times_and_sizes_read_short():
    assert render_stats.seconds_text(9.79e3) == "2.7 h"
    assert render_stats.seconds_text(46.2) == "46 s"
    assert render_stats.seconds_text(4.62) == "4.6 s"
    assert render_stats.seconds_text(0.0321) == "32 ms"
    assert render_stats.seconds_text(0.00045) == "0.45 ms"
    assert render_stats.seconds_text(450.0) == "7.5 min"
    assert render_stats.seconds_text(59.9) == "1 min" and render_stats.seconds_text(5.0) == "5 s"
    assert render_stats.bytes_text(443_000) == "443 kB"
    assert render_stats.bytes_text(8_440_000) == "8.4 MB"
    assert render_stats.bytes_text(104) == "104 B"
    assert render_stats.human_count(1234) == "1.2k"


def test_the_estimate_renders_a_small_sample_of_the_same_view():
    camera = dict(resolution_x=480, resolution_y=360, resolution_percentage=50, lens=50.0)
    sample, ratio = compare.sample_camera(camera)
    width, height = sample["resolution_x"], sample["resolution_y"]
    assert sample["resolution_percentage"] == 100 and sample["lens"] == 50.0
    assert abs(width / height - 480 / 360) < 0.1
    assert 0.5 * compare.SAMPLE_PIXELS < width * height <= 1.5 * compare.SAMPLE_PIXELS
    assert ratio * width * height == pytest.approx(240 * 180)
    tiny = dict(camera, resolution_x=8, resolution_y=6, resolution_percentage=100)
    assert compare.sample_camera(tiny) == (tiny, 1.0)
