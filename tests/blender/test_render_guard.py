"""render_engine's F12 guard (the lock-up of issues 12 and 40): the render job's thread enters and leaves the
engine only while the main thread is parked in a timer, outside any draw. render_pre on the job thread
raises the switch interval and waits until the main thread parks; the main thread's timer stays parked
until render() has begun (or the render ended, or its limit passed); inside render() the interval is
Python's own; when render() ends it parks the main thread again and render_post lets it go; the guard
ends once the render job has ended. These call the handlers as Blender does: from another thread, and
from the main one."""
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
    # A stalled test machine must not end a wait by its limit before the test looks at it.
    monkeypatch.setattr(render_engine, "_MAIN_THREAD_WAIT_SECONDS", 120.0)
    render_engine._release_render_guard()
    render_engine._park_requested.clear()
    interval = sys.getswitchinterval()
    yield scene
    render_engine._park_over.set()
    render_engine._release_render_guard()
    render_engine._park_requested.clear()
    sys.setswitchinterval(interval)


def on_job_thread(function, *args):
    """function(*args) as the render job's thread runs it; returns the thread once it asks the main thread
    to park (the interval raised)."""
    job = threading.Thread(target=function, args=args, daemon=True)
    job.start()
    deadline = time.monotonic() + 60.0
    while not render_engine._park_requested.is_set() and job.is_alive():
        assert time.monotonic() < deadline, "the job thread never asked the main thread to park"
        time.sleep(0.001)
    return job


def test_render_pre_waits_until_the_main_thread_parks_which_stays_parked_until_render_begins(raylab_scene):
    interval = sys.getswitchinterval()
    job = on_job_thread(render_engine._guard_render_start, raylab_scene)
    assert sys.getswitchinterval() == render_engine._SWITCH_INTERVAL_WHILE_RENDERING
    time.sleep(0.05)  # the main thread runs Python meanwhile: the job thread still waits for a timer
    assert job.is_alive(), "render_pre returned before the main thread parked"
    # Blender calls render() once render_pre has returned: here a thread that enters it once the main
    # thread is parked, and notes whether the main thread was still parked then.
    seen = {}

    def blender_calls_render():
        job.join(60.0)
        seen["main parked when render() began"] = parked.wait(60.0)
        render_engine._entering_render()

    parked = threading.Event()
    caller = threading.Thread(target=blender_calls_render, daemon=True)
    caller.start()
    original = render_engine._park_over.wait

    def park(timeout):
        parked.set()
        try:
            return original(60.0)  # not its limit: the test waits for render() itself
        finally:
            parked.clear()
    render_engine._park_over.wait = park
    try:
        render_engine._flush_last_renders()  # the timer, here on the main thread: parks until render() begins
    finally:
        del render_engine._park_over.wait
    caller.join(60.0)
    assert not job.is_alive() and not caller.is_alive()
    assert seen == {"main parked when render() began": True}
    # inside render() the interval is Python's own again (render() put it back as it began)
    assert sys.getswitchinterval() == interval


def test_render_end_parks_the_main_thread_until_render_post(raylab_scene):
    interval = sys.getswitchinterval()
    job = on_job_thread(render_engine._leaving_render)
    assert sys.getswitchinterval() == render_engine._SWITCH_INTERVAL_WHILE_RENDERING

    def post():
        job.join(60.0)  # render() returned while the main thread was parked
        render_engine._guard_render_end(raylab_scene)
    poster = threading.Thread(target=post, daemon=True)
    poster.start()
    started = time.monotonic()
    render_engine._park_main_thread()  # returns once render_post ran, well before its limit
    poster.join(60.0)
    assert not job.is_alive() and not poster.is_alive()
    assert time.monotonic() - started < 60.0
    render_engine._flush_last_renders()  # no render job runs here: the guard ends
    assert sys.getswitchinterval() == interval


def test_the_main_thread_parks_for_a_limited_time_when_render_never_begins(raylab_scene, monkeypatch):
    monkeypatch.setattr(render_engine, "_PARK_SECONDS", 0.05)
    job = on_job_thread(render_engine._guard_render_start, raylab_scene)
    render_engine._flush_last_renders()  # parks, nobody calls render(): back after _PARK_SECONDS
    job.join(60.0)
    assert not job.is_alive()


def test_a_record_the_timer_cannot_write_stays_pending_and_the_timer_lives_on(raylab_scene, monkeypatch):
    """Writes refused (Blender's flag at "no writes"): the timer must not raise, which would unregister it."""
    from raylab.blender import render_stats
    refused = {"count": 0}

    class Refusing:
        def __setitem__(self, key, value):
            refused["count"] += 1
            raise AttributeError("Writing to ID classes in this context is not allowed")

    class Scenes:
        def get(self, name):
            return Refusing()
    monkeypatch.setattr(render_engine.bpy, "data", type("Data", (), {"scenes": Scenes()})())
    render_engine._pending_records["Scene"] = {"rays": 1}
    try:
        assert render_engine._flush_last_renders() == render_engine._TIMER_SECONDS
        assert refused["count"] == 1 and "Scene" in render_engine._pending_records
    finally:
        render_engine._pending_records.clear()
    assert render_stats.LAST_RENDER == "raylab_last_render"


def test_render_pre_on_the_main_thread_or_for_another_engine_changes_nothing(raylab_scene):
    interval = sys.getswitchinterval()
    render_engine._guard_render_start(raylab_scene)  # bpy.ops.render.render() from a script: main thread
    assert sys.getswitchinterval() == interval and not render_engine._park_requested.is_set()
    raylab_scene.render.engine = 'BLENDER_WORKBENCH'
    job = threading.Thread(target=render_engine._guard_render_start, args=(raylab_scene,))
    job.start()
    job.join(60.0)
    assert not job.is_alive() and sys.getswitchinterval() == interval
