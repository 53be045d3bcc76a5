"""The texts say what is drawn: every colour a level's text.md (or the README's level pictures) names is
the colour the add-on draws that thing in, and every place a text sends the student to is where the
panel or the operator really is."""
import os
import re
import sys
import tomllib

import numpy as np
import pytest

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir)
sys.path.insert(0, os.path.join(ROOT, "addon"))
from raylab.blender import compare, probe, properties, tree_view  # noqa: E402
from raylab.blender.experiments import leak  # noqa: E402

LEVELS_DIR = os.path.join(ROOT, "levels")
TEXTS = sorted(f"levels/{d}/text.md" for d in os.listdir(LEVELS_DIR)
               if os.path.exists(os.path.join(LEVELS_DIR, d, "text.md")))

# What a reader calls each colour; a drawn colour is named by the nearest of these.
NAMED = {"red": (1.0, 0.1, 0.1), "orange": (1.0, 0.55, 0.1), "yellow": (1.0, 0.9, 0.1), "green": (0.2, 1.0, 0.2),
         "cyan": (0.2, 0.85, 1.0), "blue": (0.1, 0.2, 1.0), "grey": (0.62, 0.62, 0.7), "pink": (1.0, 0.15, 0.55),
         "white": (1.0, 1.0, 1.0), "black": (0.0, 0.0, 0.0)}
COLOUR_WORD = re.compile(r"\b(" + "|".join(NAMED) + r"|gray|magenta|purple)\b", re.IGNORECASE)


def aabb_1_line_colour():
    with open(os.path.join(LEVELS_DIR, "aabb_1", "level.toml"), "rb") as f:
        return tomllib.load(f)["raylab"]["line_color"]


# (file, the phrase that names a colour, the colour drawn for it). Every colour word in a level's
# text.md must be covered here, so a new one cannot go unchecked.
CLAIMS = [
    ("levels/aabb_1/text.md", "green box", aabb_1_line_colour),
    ("levels/bvh_2/text.md", "cyan ones hit", lambda: probe.STATUS_COLORS["hit_object"]),
    ("levels/bvh_2/text.md", "grey ones missed the root", lambda: probe.STATUS_COLORS["missed_root"]),
    ("levels/bvh_2/text.md", "orange ones missed every box", lambda: probe.STATUS_COLORS["missed_nodes"]),
    ("levels/bvh_2/text.md", "yellow ones tested triangles", lambda: probe.STATUS_COLORS["missed_triangles"]),
    ("levels/where_methods_fail/text.md", "escaped rays in red", lambda: leak.RAY_COLOR),
    ("levels/where_methods_fail/text.md", "yellow dot", lambda: leak.CROSSING_COLOR),
    ("levels/where_methods_fail/text.md", "turn up in orange", lambda: leak.CONTRACT_COLOR),
    ("levels/where_methods_fail/text.md", "over the red ones", lambda: leak.RAY_COLOR),
    ("levels/why_sah/text.md", "x red", lambda: tree_view.AXIS_COLOURS[0]),
    ("levels/why_sah/text.md", "y green", lambda: tree_view.AXIS_COLOURS[1]),
    ("levels/why_sah/text.md", "z blue", lambda: tree_view.AXIS_COLOURS[2]),
    ("levels/why_sah/text.md", "a leaf in grey", lambda: tree_view.LEAF_LINE),
    ("README.md", "escaped rays are drawn in red", lambda: leak.RAY_COLOR),
    ("README.md", "closed sphere (red)", lambda: leak.RAY_COLOR),
    ("README.md", "yellow dot", lambda: leak.CROSSING_COLOR),
]


def colour_name(rgb):
    rgb = np.asarray(rgb[:3], dtype=float)
    return min(NAMED, key=lambda name: np.linalg.norm(rgb - NAMED[name]))


def read(relative):
    with open(os.path.join(ROOT, relative), encoding="utf-8") as f:
        return " ".join(f.read().split())  # a phrase may wrap onto the next line


@pytest.mark.parametrize("path, phrase, drawn", CLAIMS, ids=[f"{c[0]}: {c[1]}" for c in CLAIMS])
def test_the_colour_a_text_names_is_the_colour_drawn(path, phrase, drawn):
    assert phrase in read(path), f"{path} no longer says {phrase!r}: update CLAIMS"
    word = COLOUR_WORD.search(phrase).group(1).lower()
    assert colour_name(drawn()) == word, f"{path} says {phrase!r}, but it is drawn {colour_name(drawn())}"


@pytest.mark.parametrize("path", TEXTS)
def test_every_colour_word_of_a_level_text_is_checked(path):
    said = [m.group(1).lower() for m in COLOUR_WORD.finditer(read(path))]
    checked = [COLOUR_WORD.search(phrase).group(1).lower() for file, phrase, _ in CLAIMS if file == path]
    assert sorted(said) == sorted(checked), f"{path} names colours {said}; CLAIMS checks {checked}"


# (text, structure whose statuses it teaches): each status the text names in bold reads in the probe's
# words for that structure.
STATUS_TEXTS = [("levels/aabb_2/text.md", "aabb"), ("levels/octree_2/text.md", "octree")]


@pytest.mark.parametrize("path, structure", STATUS_TEXTS)
def test_the_probe_says_what_the_tutorial_says(path, structure):
    """Issue 27, item 12: AABB 2's text says "Box hit, object missed" where the probe said "Entered nodes
    with triangles, hit none"; Octree 2 says "misses the root cube" where it said "missed every object's
    box". Every bold status of the text opens one of the probe's sentences for the structure, and the
    sentence's words after the status are the text's words."""
    words = probe.BOX_WORDS if structure == "aabb" else probe.STATUS_WORDS
    text = read(path)
    named = re.findall(r"- \*\*([^*]+)\*\*(?: \([^)]+\))?: (.+?)(?= - \*\*|$)", text)
    assert len(named) >= 3, named
    root = properties.api.STRUCTURE_INFO[structure]["root_name"]
    for status, meaning in named:
        sentences = [w.format(root=root) for w in words.values() if w.startswith(status)]
        assert sentences, f"{path}: the probe never says {status!r}"
        said = sentences[0].split(": ", 1)[1]
        # The probe's sentence is the text's, shortened: its first five words are the text's.
        first = " ".join(said.replace(",", "").split()[:5]).lower()
        assert first in meaning.replace(",", "").lower(), f"{path}: {status} means {meaning!r}; the probe says {said!r}"


def test_compare_structures_is_where_the_texts_say():
    """The comparison's panel is in the 3D viewport's sidebar, not in the render settings."""
    panel = compare.RAYLAB_PT_comparison
    assert (panel.bl_space_type, panel.bl_region_type) == ('VIEW_3D', 'UI')
    assert any("Compare Structures" in read(path) for path in TEXTS)
    for path in TEXTS:
        if "Compare Structures" in read(path):
            text = read(path)
            assert "render settings" not in text.split("Compare Structures", 1)[1][:60], path
            assert "sidebar" in text, f"{path} mentions Compare Structures without saying where it is"


def test_the_line_colour_default_is_the_green_the_levels_name():
    assert colour_name(properties.VRT_GREEN) == "green"


@pytest.fixture
def level_scenes():
    """Opens levels (levels.open_level(bpy.context, id)); afterwards the window shows the scene it showed and
    the level scenes are gone, as the other test files expect."""
    import bpy
    from raylab.blender import levels
    before = bpy.context.window.scene
    yield lambda level_id: levels.open_level(bpy.context, level_id)
    bpy.context.window.scene = before
    for level_scene in [s for s in bpy.data.scenes if levels.state(s) is not None]:
        levels._remove_scene(level_scene)


def test_bvh_2_teaches_the_binary_tree_and_its_numbers_are_the_probe_s(level_scenes):
    """Issue 42 item 8: BVH 2 says a ray tests two child boxes in the binary tree the builder makes, and what
    the 8-wide walk does instead, with the numbers the probe reads for the level's first ray."""
    from raylab.blender import structure_cache
    scene = level_scenes("bvh_2")
    text = read("levels/bvh_2/text.md")
    assert "binary tree" in text and "tests the two child boxes" in text
    result = probe.evaluate_probe(scene)
    said = re.search(r"box tests (\d+), nodes visited (\d+), triangle tests (\d+)", text)
    assert said, "BVH 2 no longer quotes the probe's counts"
    assert tuple(map(int, said.groups())) == (result["box_tests"], result["nodes_visited"], result["triangle_tests"])
    model = structure_cache.scene_model(scene)
    width = model.entry(model.instances[0]).structure.tree()["width"]
    assert f"{width}-wide" in text and f"up to {width} children" in text
    origins, directions, _ = probe.probe_rays(scene)
    (part,) = model.scene.story(origins[0], directions[0]).instances
    tree = model.entry(model.instances[0]).structure.tree()
    parents = tree["parent"][part.story.boxes["node"]]
    children = [int((parents == p).sum()) for p in dict.fromkeys(parents[parents >= 0].tolist())]
    told = f"{children[0]} at the root, " + " and ".join(map(str, children[1:])) + f" below it ({sum(children)})"
    assert told in text
    # the scene's top level (1 box) and the mesh's root box (1) make up the rest
    assert 1 + 1 + sum(children) == result["box_tests"]


def test_octree_2_offers_the_fan_and_says_what_its_summary_adds_up(level_scenes):
    """Issue 42 item 10: the fan is one click away in Octree 2, and its last line adds up the fan's work."""
    scene = level_scenes("octree_2")
    with open(os.path.join(LEVELS_DIR, "octree_2", "level.toml"), "rb") as f:
        assert "raylab.fan_enabled" in tomllib.load(f)["controls"]
    assert "adds up the triangle tests and box tests" in read("levels/octree_2/text.md")
    scene.raylab.fan_enabled = True
    assert any(line.startswith("fan of ") and "triangle tests" in line and "box tests" in line
               for line in probe.status_text(scene))
