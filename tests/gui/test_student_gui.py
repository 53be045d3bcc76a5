"""A student's second afternoon, in a real Blender window under Xvfb: a scripted student does every task
of every level as its text says, in every way the text allows, and the add-on's own handlers and timer
tick them. tests/gui/student_session.py does it, in one Blender session; this reads what the Tasks panel
showed after each step.
"""
import os

import numpy as np
import pytest

from gui_util import OUT, ROOT, Region, changed, dilate, load_rgb, run_session, start_blend

LEVELS_DIR = os.path.join(ROOT, "levels")
LEVEL_IDS = sorted(d for d in os.listdir(LEVELS_DIR) if os.path.exists(os.path.join(LEVELS_DIR, d, "level.toml")))
# The rod task says "2 m or more along any axis, either way".
ROD_WAYS = ("rod up", "rod down", "rod right", "rod left", "rod away", "rod toward")


@pytest.fixture(scope="module")
def session_report(tmp_path_factory):
    return run_session("student_session.py", "student_session.json", start_blend(tmp_path_factory.mktemp("student")),
                       outputs=("student_bvh_1_leaves_8.png", "student_bvh_1_leaves_1.png"),
                       extra=["--enable-event-simulate"])


@pytest.fixture(scope="module")
def runs(session_report):
    return session_report["runs"]


def test_no_raylab_draw_lets_go_of_the_interpreter_lock(session_report):
    """While the student works through every level, F12 included, no raylab panel, header or menu lets go
    of Python's interpreter lock in the middle of its draw (draw_lock_watch.py): a draw that does lets
    F12's job thread leave Blender refusing every operator afterwards."""
    ours = {key: stack for key, stack in session_report["draws_letting_go"].items() if key.startswith("RAYLAB_")}
    assert not ours, "\n\n".join(f"{key}:\n{stack}" for key, stack in ours.items())


def runs_of(runs, level_id):
    found = [run for run in runs if run["level"] == level_id]
    assert found, f"the student never opened {level_id}"
    return found


@pytest.mark.parametrize("level_id", LEVEL_IDS)
def test_every_task_ticks_in_order_when_the_student_does_it(runs, level_id):
    """After each step the Tasks panel shows the tasks done so far ticked, and no other: a task ticks when
    its text is done, not before, and only after the ones above it."""
    for run in runs_of(runs, level_id):
        where = f"{level_id} ({run['way']})"
        assert "error" not in run, f"{where}: {run['error']}"
        assert run["steps"], where
        count = len(run["tasks"])
        for step in run["steps"]:
            expected = [True] * step["expect"] + [False] * (count - step["expect"])
            assert step["ticks"] == expected, f"{where}, after {step['did']!r}: {step}"
    assert any(all(run["steps"][-1]["ticks"]) for run in runs_of(runs, level_id)), \
        f"{level_id}: no run ticked every task"


def test_the_rod_task_ticks_along_every_axis_either_way(runs):
    """Where does the work go: 2 m along any axis, either way, makes the BVH's hardest pixel cheaper, and
    the task ticks."""
    rod_runs = {run["way"]: run for run in runs_of(runs, "where_work_goes")}
    assert set(ROD_WAYS) <= set(rod_runs)
    for way in ROD_WAYS:
        steps = rod_runs[way]["steps"]
        start, moved = steps[0]["bvh_hardest"], steps[-1]["bvh_hardest"]
        assert moved < start and all(steps[-1]["ticks"]), f"{way}: {steps}"
    # Moved clear in any direction, the hardest pixel costs the same: the goat's own.
    assert len({rod_runs[way]["steps"][-1]["bvh_hardest"] for way in ROD_WAYS}) == 1


def test_the_probe_pixel_task_puts_the_probe_on_the_octree_s_hardest_pixel(runs):
    for run in runs_of(runs, "where_work_goes"):
        step = run["steps"][1]
        assert step["triangle_tests"] == step["octree_hardest"], run["way"]


def test_bvh_1_s_leaf_size_task_changes_the_boxes_drawn(runs):
    """With the leaves shown, Leaf size 1 visibly changes the viewport (the task's point)."""
    (run,) = runs_of(runs, "bvh_1")
    before, after = (Region(run["shots"][name]["region"], run["shots"][name]["window_height"]).crop(
        load_rgb(os.path.join(OUT, name))) for name in ("student_bvh_1_leaves_8.png", "student_bvh_1_leaves_1.png"))
    # The region's top strip holds the header and the corner text, the right its sidebar: the boxes are
    # drawn in the middle.
    middle = (slice(60, before.shape[0] - 20), slice(0, int(before.shape[1] * 0.7)))
    assert changed(before[middle], after[middle], threshold=0.1).mean() > 0.02


def test_the_tree_view_draws_the_tree_and_the_picked_node_s_box(runs):
    """Why SAH?: the tree is drawn in its frame over the view (node squares in the heat colours on the dark
    frame), and the picked node's box is drawn white where its corners fall in the view."""
    (run,) = runs_of(runs, "why_sah")
    name = "student_why_sah_tree.png"
    region = Region(run["shots"][name]["region"], run["shots"][name]["window_height"])
    image = region.crop(load_rgb(os.path.join(OUT, name)))
    x, y, width, height = run["tree_frame"]
    top, left = region.row_col(x, y + height)
    frame = image[top + 24:top + height, left:left + width]  # below the frame's title
    assert (frame.max(axis=-1) < 0.15).mean() > 0.5, "the tree's dark frame"
    assert (frame.max(axis=-1) - frame.min(axis=-1) > 0.3).sum() > 20, "node squares in colour"
    white = dilate(np.all(image > 0.9, axis=-1), 2)
    seen = [region.row_col(cx, cy) for cx, cy in filter(None, run["picked_box_pixels"])
            if not (x <= cx <= x + width and y <= cy <= y + height)]
    seen = [(r, c) for r, c in seen if 30 < r < image.shape[0] - 5 and 5 < c < image.shape[1] * 0.75]
    assert len(seen) >= 3, run["picked_box_pixels"]
    assert sum(bool(white[r, c]) for r, c in seen) >= len(seen) - 1, "the picked box's corners drawn white"


def test_following_the_cost_down_ends_on_the_costliest_leaf_and_the_panel_says_its_share(runs):
    """Why SAH?'s task: Costliest from the root ends on the leaf holding the most cost, and the panel
    reads it in triangle tests, its share of the tree's not a bare 0.0% (issue 42, items 2 and 3)."""
    (run,) = runs_of(runs, "why_sah")
    (down,) = [s for s in run["steps"] if s["did"] == "Costliest, down to a leaf"]
    assert down["node"] == down["costliest_leaf"], down
    (share,) = [line for line in down["panel"] if "of the tree's" in line]
    assert "triangle tests" in share and "0.0%" not in share, share


def test_a_click_in_the_tree_view_picks_the_node_and_up_picks_its_parent(runs):
    (run,) = runs_of(runs, "why_sah")
    assert run["click"]["picked"] == run["click"]["aimed"] != 0, run["click"]
    assert run["key_up"]["picked"] == run["key_up"]["parent"], run["key_up"]


def test_the_race_s_animation_tasks_refit_then_rebuild_while_playing(runs):
    (run,) = runs_of(runs, "race")
    refit, rebuild = run["steps"][-2], run["steps"][-1]
    assert refit["frames"] >= 3 and rebuild["frames"] >= 3
    assert refit["refits"] > 0  # the BVH refitted as the wave played
    assert rebuild["builds"] > 0 and rebuild["refits"] == 0  # and built anew each frame on Rebuild


def test_what_the_tasks_ask_the_student_to_read_is_there(runs):
    """AABB 2 asks to read Rays ignored after F12; Octree 2 how many triangles the ray on the bunny
    tested: a few of the bunny's, not all."""
    (goat,) = [run for run in runs_of(runs, "aabb_2") if run["way"] == "goat"]
    assert goat["steps"][-1]["rays_ignored"] > 0
    assert goat["render_under_tasks"], "the Tasks panel never drew the last render's numbers"  # issue 42, 6
    (octree_2,) = runs_of(runs, "octree_2")
    hit = octree_2["steps"][-1]
    assert hit["status"] == "hit_object" and 0 < hit["triangle_tests"] < hit["triangle_total"] / 10
