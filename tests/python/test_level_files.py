"""The level format in plain Python (no bpy): every shipped level reads, and a broken condition is refused
with the file it is in."""
import os
import pathlib
import sys

import pytest

from raylab.blender import levels

LEVELS_DIR = str(pathlib.Path(__file__).resolve().parents[2] / "levels")  # the checkout's, whichever add-on copy


def test_every_level_reads_without_blender():
    found, errors = levels.available_levels(LEVELS_DIR)
    assert found and errors == []
    assert "bpy" not in sys.modules
    for level in found:
        assert level.blocks and all(task.condition for task in level.tasks)


def test_a_bad_condition_names_its_file():
    with pytest.raises(levels.LevelError, match="level.toml task 1"):
        levels.validate_condition({"property": "raylab.max_depth"}, "level.toml task 1")


@pytest.mark.parametrize("condition, message", [
    ({"id_property": "raylab_heat_maps.structures.bvh.hardest", "decreased": False}, "decreased takes true"),
    ({"id_property": "raylab_heat_maps..bvh", "exists": True}, "dots between its keys"),
    ({"probe_pixel_near": "raylab_heat_maps.structures.octree.probe_pixel", "within": -1}, "whole number"),
    ({"probe_pixel_near": "raylab_heat_maps.structures.octree.probe_pixel", "within": 2.5}, "whole number"),
    ({"probe_pixel_near": "raylab_heat_maps.structures.octree.probe_pixel"}, "takes exactly one of"),
    ({"probe_pixel_near": "x", "within": 3, "id_property": "x"}, "exactly one of"),
])
def test_the_heat_map_conditions_refuse_what_they_cannot_check(condition, message):
    with pytest.raises(levels.LevelError, match=message):
        levels.validate_condition(condition, "level.toml task 2")


def test_the_heat_map_conditions_read():
    levels.validate_condition({"id_property": "raylab_heat_maps.structures.bvh.hardest", "decreased": True}, "t")
    levels.validate_condition({"probe_pixel_near": "raylab_heat_maps.structures.octree.probe_pixel",
                               "within": 3}, "t")


def _level_with_objects(tmp_path, objects):
    folder = tmp_path / "extra"
    folder.mkdir()
    (folder / "text.md").write_text("# Extra\n\nA level with an extra object.\n")
    (folder / "level.toml").write_text('id = "extra"\norder = 1\ntitle = "Extra"\ngoal = "g"\n' + objects
                                       + '[mesh]\nfile = "goathead.obj"\n')
    return str(folder)


@pytest.mark.parametrize("objects, message", [
    ('[[objects]]\nfile = "rod.obj"\n', "'name' is missing"),
    ('[[objects]]\nname = "Rod"\nfile = "rod.obj"\nsize = -1.0\n', "size must be positive"),
    ('[[objects]]\nname = "Rod"\nfile = "rod.obj"\nlocation = [0.0, 1.0]\n', "three numbers"),
    ('[[objects]]\nname = "Rod"\nfile = "rod.obj"\nspin = true\n', "unknown keys"),
    ('[[objects]]\nname = "Rod"\nfile = "rod.obj"\n[[objects]]\nname = "Rod"\nfile = "sphere.obj"\n',
     "a second object named"),
    ('objects = "rod.obj"\n', "must be a list"),
])
def test_a_broken_extra_object_names_its_file_and_the_reason(tmp_path, objects, message):
    with pytest.raises(levels.LevelError, match=message):
        levels.load_level(_level_with_objects(tmp_path, objects))


def test_the_extra_objects_are_read_in_order(tmp_path):
    level = levels.load_level(_level_with_objects(
        tmp_path, '[[objects]]\nname = "Rod"\nfile = "rod.obj"\nsize = 1.5\nlocation = [1, 2, 3]\n'))
    assert level.objects == [{"name": "Rod", "file": "rod.obj", "size": 1.5, "location": [1, 2, 3]}]


def test_from_memory_the_levels_are_the_ones_read_last(tmp_path, monkeypatch):
    """The panels' draws ask for the levels from memory and must not touch the files (each file-system
    call lets go of Python's interpreter lock, see reading.available_levels): the levels read last are
    the answer, and a read from the disk (the tasks' timer) sees an edit."""
    root = str(tmp_path)
    folder = _level_with_objects(tmp_path, "")
    assert [level.title for level in levels.available_levels(root)[0]] == ["Extra"]
    with open(os.path.join(folder, "level.toml")) as f:
        text = f.read()
    with open(os.path.join(folder, "level.toml"), "w") as f:
        f.write(text.replace('title = "Extra"', 'title = "Edited"'))
    os.utime(os.path.join(folder, "level.toml"), (1e9, 1e9))  # another mtime, however coarse the clock

    def no_disk(*_args):
        raise AssertionError("the disk was read by a draw")
    for name in ("listdir", "stat"):
        monkeypatch.setattr(os, name, no_disk)
    assert levels.find_level("extra", root, from_memory=True).title == "Extra"
    assert [level.title for level in levels.available_levels(root, from_memory=True)[0]] == ["Extra"]
    monkeypatch.undo()
    assert levels.find_level("extra", root).title == "Edited"
    assert levels.find_level("extra", root, from_memory=True).title == "Edited"
