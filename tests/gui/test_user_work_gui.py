"""A level never deletes the user's work (issue 27, item 1), in a real window: with AABB 1 open, New
Scene > Copy Settings carried the level's state into the user's new scene, and Next deleted that scene with
the cube the user had added. Now the new scene is the user's (the raylab tab shows no level over it), Next
keeps it and its cube, Undo brings back the step, and a cube added to the level's own scene outlives the
level.

Runs tests/gui/user_work_session.py inside Blender (with --enable-event-simulate, to click the raylab tab).
"""

import pytest

from gui_util import run_session, start_blend

AABB_1 = "raylab: AABB 1: the bounding box"


@pytest.fixture(scope="module")
def steps(tmp_path_factory):
    return run_session("user_work_session.py", "user_work.json", start_blend(tmp_path_factory.mktemp("user_work")),
                       extra=["--enable-event-simulate"])


def test_a_new_scene_made_in_a_level_starts_without_the_level(steps):
    assert steps["level"]["level"] == "aabb_1" and steps["level"]["scene"] == AABB_1
    new = steps["new_scene"]
    assert new["scene"] != AABB_1
    assert new["level"] is None, "the raylab tab shows the level's goal and tasks over the user's new scene"
    assert new["is_level"][new["scene"]] is False


def test_next_keeps_the_users_scene_and_cube(steps):
    mine = steps["new_scene"]["scene"]
    after = steps["after_next"]
    assert mine in after["scenes"], "the user's scene was deleted"
    assert "My cube" in after["scenes"][mine], "the user's cube was deleted"
    assert after["level"] == "aabb_1"  # from a scene that is not a level, Next opens the first level
    assert sum(after["is_level"].values()) == 1  # and the level's first scene made way for it


def test_undo_brings_back_the_step(steps):
    before, after = steps["after_next"], steps["after_undo"]
    mine = steps["new_scene"]["scene"]
    # Undo goes back to the cube's step, before the script renamed it (a rename from a script is no step).
    assert after["scene"] == mine and len(after["scenes"][mine]) == 1 and after["scenes"][mine][0].startswith("Cube")
    assert after["level"] is None
    assert set(after["scenes"]) == {*steps["new_scene"]["scenes"]}, (after["scenes"], steps["new_scene"]["scenes"])
    assert before != after


def test_a_cube_added_to_the_level_scene_outlives_the_level(steps):
    after = steps["after_next_from_level"]
    holding = [name for name, objects in after["scenes"].items() if "My cube in the level" in objects]
    assert len(holding) == 1 and not after["is_level"][holding[0]], after
    assert after["scenes"][holding[0]] == ["My cube in the level"]  # the level's own objects went
    assert after["level"] == "aabb_2"
