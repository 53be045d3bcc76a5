"""Every list of structure kinds in the prose is the core's table's (tools/kind_lists.py), and a level's
text shows the list without its markers."""
import importlib.util
import pathlib

import raylab
from raylab.blender.levels import reading

ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("kind_lists", ROOT / "tools" / "kind_lists.py")
kind_lists = importlib.util.module_from_spec(spec)
spec.loader.exec_module(kind_lists)


def test_every_marked_list_and_the_add_ons_description_name_the_kinds_of_the_core():
    assert kind_lists.stale() == []
    assert kind_lists.kinds("all") == ", ".join(raylab.STRUCTURES)


def test_a_new_kind_makes_a_marked_list_stale(monkeypatch):
    table = dict(raylab.STRUCTURE_INFO, kd_tree=dict(raylab.STRUCTURE_INFO["bvh"], name="kd_tree", label="k-d tree"))
    monkeypatch.setattr(raylab, "STRUCTURE_INFO", table)
    text = "<!--kinds:boxes-->aabb, octree, bvh, grid<!--/kinds-->"
    assert kind_lists.rewritten(text) == "<!--kinds:boxes-->aabb, octree, bvh, grid, kd_tree<!--/kinds-->"
    assert any("k-d tree" in what for _, what in kind_lists.stale())


def test_a_levels_text_shows_the_list_not_its_markers():
    blocks = reading.read_text(str(ROOT / "levels" / "where_work_goes" / "text.md"))
    text = " ".join(str(part) for block in blocks for part in block[1:])
    assert "<!--" not in text and ", ".join(raylab.STRUCTURES) in text
