"""render_engine's F12 guard (issue 12's lock-up): render_pre on the render job's thread makes Python keep
the interpreter with the running thread for 10 s instead of 5 ms, and waits for a main-thread timer before
Blender may call the engine, so render() never starts inside a main-thread draw; the guard ends once the
render job has ended. These call the handler as Blender does: from another thread, and from the main one."""
import sys
import threading
import time

import bpy
import pytest

from raylab.blender import render_engine


@pytest.fixture
def raylab_scene(monkeypatch):
    scene = bpy.context.scene
    scene.render.engine = 'RAYLAB'
    # A stalled test machine must not end the wait by its timeout before the test looks at it.
    monkeypatch.setattr(render_engine, "_MAIN_THREAD_WAIT_SECONDS", 120.0)
    render_engine._release_render_guard()
    interval = sys.getswitchinterval()
    yield scene
    render_engine._release_render_guard()
    sys.setswitchinterval(interval)


def start_job_thread(scene):
    """render_pre as the render job's thread runs it; returns the thread once it waits (interval raised)."""
    job = threading.Thread(target=render_engine._guard_render_start, args=(scene,), daemon=True)
    job.start()
    deadline = time.monotonic() + 60.0
    while sys.getswitchinterval() != render_engine._SWITCH_INTERVAL_WHILE_RENDERING and job.is_alive():
        assert time.monotonic() < deadline, "render_pre never raised the switch interval"
        time.sleep(0.001)
    return job


def test_render_pre_waits_for_a_main_thread_timer_then_the_timer_ends_the_guard(raylab_scene):
    interval = sys.getswitchinterval()
    job = start_job_thread(raylab_scene)
    assert sys.getswitchinterval() == render_engine._SWITCH_INTERVAL_WHILE_RENDERING
    time.sleep(0.05)  # the main thread runs Python meanwhile: the job thread still waits for a timer
    assert job.is_alive(), "render_pre returned before any main-thread timer ran"
    render_engine._flush_last_renders()  # the timer, here on the main thread, with no render job running
    job.join(60.0)
    assert not job.is_alive(), "render_pre still waits after the main-thread timer ran"
    # no render job runs here, so that same timer call also ended the guard
    assert sys.getswitchinterval() == interval


def test_a_second_render_pre_while_the_guard_is_held_waits_again_and_keeps_one_saved_interval(raylab_scene):
    interval = sys.getswitchinterval()
    first = start_job_thread(raylab_scene)
    render_engine._main_thread_between_calls.set()  # the timer's signal alone, the guard kept
    first.join(60.0)
    assert not first.is_alive()
    second = start_job_thread(raylab_scene)  # the next F12 before a timer released the last guard
    time.sleep(0.05)
    assert second.is_alive(), "a render_pre while the last guard is held must wait for the main thread too"
    render_engine._flush_last_renders()
    second.join(60.0)
    assert not second.is_alive()
    assert sys.getswitchinterval() == interval  # one saved interval, restored once


def test_render_pre_on_the_main_thread_or_for_another_engine_changes_nothing(raylab_scene):
    interval = sys.getswitchinterval()
    render_engine._guard_render_start(raylab_scene)  # bpy.ops.render.render() from a script: main thread
    assert sys.getswitchinterval() == interval
    raylab_scene.render.engine = 'BLENDER_WORKBENCH'
    job = threading.Thread(target=render_engine._guard_render_start, args=(raylab_scene,))
    job.start()
    job.join(60.0)
    assert not job.is_alive() and sys.getswitchinterval() == interval
