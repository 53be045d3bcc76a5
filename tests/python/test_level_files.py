"""The level format in plain Python (no bpy): every shipped level reads, and a broken condition is refused
with the file it is in."""
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
