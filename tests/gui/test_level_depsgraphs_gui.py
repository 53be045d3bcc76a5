"""No depsgraph keeps a copy of an object a level switch deleted (issue 40, item 7). Blender keeps the
depsgraph of a scene that was shown, and evaluates it again only when the scene is shown again; its GPU
garbage collection walks every scene's depsgraph and reads each copy's original. A level left with an
object of the student's is kept as their scene, the level's own objects deleted from it: its depsgraph
held copies of the deleted level mesh, camera and sun, whose originals were freed, which Blender 5.2's
garbage collection read (object_orig->runtime->select_id) when it crashed in CI during the race level.
On 3.4 that read hits freed memory without crashing (runtime is inside the object there), so what is
asserted is the cause: no depsgraph holds such a copy, after the switch and after the mesh swap, the
collection running every second meanwhile.

Runs tests/gui/level_depsgraphs_session.py."""
from gui_util import run_session, start_blend


def test_no_depsgraph_keeps_objects_the_level_switch_deleted(tmp_path):
    report = run_session("level_depsgraphs_session.py", "level_depsgraphs.json", start_blend(tmp_path), [],
                         extra=("--debug-memory",))
    assert set(report["stale"]) == {"own cube added", "race opened", "dragon swapped in"}
    # the level left is kept for the student's cube, with a depsgraph of its own
    assert any(name.endswith("(your objects)/ViewLayer") for name in report["stale"]["race opened"]), report
    for when, depsgraphs in report["stale"].items():
        held = {name: copies for name, copies in depsgraphs.items() if copies}
        assert not held, f"{when}: depsgraphs hold copies of deleted objects: {held}"
