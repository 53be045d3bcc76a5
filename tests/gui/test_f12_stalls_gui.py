"""F12 never holds Blender's main loop (issue 40: F12 on the AABB 2 level stalled the interface 13.8 s, then
about 3 s at a time). In a real window, tests/gui/f12_stalls.py renders the AABB 2 level once per structure
while a main-thread timer ticks every 20 ms, and once more with the engine's export running Python without
a break. The longest stall per structure is printed (how long it is depends on the machine: here, with
Mesa's software OpenGL beside the render's threads on 2 cores, the main thread waits in Mesa for its own
drawing, about 1 s at a time); what is asserted is a behaviour: every render ends with its record stored,
and the main loop runs while the engine runs Python (before issue 40 the guard of render_engine.py kept
the interpreter with the render's thread for 10 s at a time: no timer ran until the export was done)."""
import json

from gui_util import run_session, start_blend


def test_f12_of_each_structure_ends_and_lets_the_main_loop_run(tmp_path):
    report = run_session("f12_stalls.py", "f12_stalls.json", start_blend(tmp_path), ["aabb_2"])
    print(json.dumps(report["stalls"], indent=1))
    for structure, stall in report["stalls"].items():
        print(f"F12 of the AABB 2 level with {structure}: the main loop's longest stall {stall['longest_s']:.3f} s "
              f"in a render of {stall['render_s']:.2f} s")
    assert not report["errors"], report["errors"]
    assert len(report["stalls"]) >= 5 and all(stall["finished"] for stall in report["stalls"].values()), report
    stretch = report["python_stretch"]
    assert stretch["main_thread_ticked"], (
        f"no main-thread timer ran during {stretch['seconds']} s of the engine's Python (render() on the job "
        f"thread): the render held the main loop")
