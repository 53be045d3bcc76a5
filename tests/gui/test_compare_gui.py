"""Compare Structures in a real Blender window under Xvfb, on the race level with the dragon (100k
triangles), where brute force alone takes minutes: the window keeps answering while it runs (a timer
fires), the sidebar shows its progress, Esc stops it and leaves nothing behind, and with a time limit
the slow structures are skipped with a note shown in the panel.

Runs tests/gui/compare_session.py inside Blender; screenshots in out/gui/compare_*.png.
"""
import os

import pytest

from gui_util import OUT, ROOT, Region, changed, load_rgb, read_report, run_gui_blender, start_blend

SCRIPT = os.path.join(ROOT, "tests", "gui", "compare_session.py")
SHOTS = ("compare_running.png", "compare_cancelled.png", "compare_skipped.png")


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    for name in ("compare_session.json", *SHOTS):
        if os.path.exists(os.path.join(OUT, name)):
            os.remove(os.path.join(OUT, name))
    blend = start_blend(tmp_path_factory.mktemp("compare"))
    process = run_gui_blender(SCRIPT, [OUT], blend, timeout=600, extra=["--enable-event-simulate"])
    return read_report(os.path.join(OUT, "compare_session.json"), process)


def sidebar(session, name):
    region = Region(session["sidebar"], session["window_height"])
    return region.crop(load_rgb(os.path.join(OUT, name)))


def test_the_window_answers_while_the_comparison_runs(session):
    assert session["triangles"] > 50000
    assert session["started"] == ["RUNNING_MODAL"]
    running = session["running"]
    assert running["job"] and running["workers"] == 1
    assert running["structure"] == "none", "brute force on the dragon is still rendering"
    assert running["still_running"], "compare_running.png was taken while the comparison ran"
    # A timer kept firing during the run (a render on the main thread would let none fire until it ended).
    assert running["ticks"] >= 2


def test_escape_cancels_and_leaves_nothing_behind(session):
    assert session["cancelled"] == dict(job=False, workers=0, stored=False, skipped=False)


def test_the_sidebar_shows_the_progress_then_the_button_again(session):
    running, cancelled = sidebar(session, SHOTS[0]), sidebar(session, SHOTS[1])
    assert changed(cancelled, running, threshold=0.1).sum() > 300


def test_with_a_time_limit_slow_structures_are_skipped_with_a_note(session):
    limited = session["limited"]
    assert limited["job"] is False and limited["workers"] == 0
    assert "none" in limited["skipped"] and "over the limit" in limited["skipped"]["none"]
    assert "bvh" in limited["compared"] and "none" not in limited["compared"]
    # The note is drawn in the panel: it differs from the panel after the cancelled run.
    assert changed(sidebar(session, SHOTS[1]), sidebar(session, SHOTS[2]), threshold=0.1).sum() > 300
