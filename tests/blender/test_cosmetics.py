"""Issue 42 item 9, the words a student reads: statuses said one way in every structure, counts with the
thousands separator (test_probe), a name wrapped at its underscore, not mid-word, "1 box", the sample of
Costliest objects said plainly (test_cost_overlay), a build over the memory budget in GiB and the panel's
setting names."""
import bpy
import numpy as np
import pytest

import raylab
from raylab.blender import probe, structure_cache, text_fit, viewport_panels


@pytest.mark.parametrize("words", [probe.STATUS_WORDS, probe.BOX_WORDS], ids=["structures", "aabb"])
def test_every_status_sentence_opens_with_its_status(words):
    for key, sentence in words.items():
        status = sentence.split(":", 1)[0]
        assert status in raylab.RAY_STATUSES and key.startswith(status), sentence


def test_a_name_wider_than_the_line_breaks_after_its_underscore():
    """The leak panel wrapped "moller_trumbor / e": a name wider than the line breaks after "_"."""
    pixels = text_fit.font_pixels(bpy.context)
    margins = 1000 - text_fit.available(bpy.context, width=1000)  # the region's width less the text's room
    room = text_fit.measure("moller_trumb", pixels)  # room for "moller_" and a little more, not the name
    lines = text_fit.lines(bpy.context, "test moller_trumbore", width=room + margins)
    assert lines == ["test", "moller_", "trumbore"], lines
    assert text_fit.lines(bpy.context, "test moller_trumbore", width=10_000) == ["test moller_trumbore"]


def test_one_box_is_a_box():
    class Entry:
        box_count = 1
        structure = raylab.build(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32),
                                 np.array([[0, 1, 2]], np.uint32), structure="aabb")
    assert viewport_panels.structure_text(Entry).startswith("1 box, ")


def test_a_build_over_the_memory_budget_reads_in_gib_and_the_panel_s_names():
    vertices = np.random.default_rng(1).random((300, 3)).astype(np.float32)
    triangles = np.arange(297, dtype=np.uint32).reshape(-1, 3)
    with pytest.raises(Exception) as caught:
        raylab.build(vertices, triangles, structure="octree", max_depth=10, leaf_size=1,
                     memory_budget=1024 ** 2)
    message = str(caught.value)
    assert "bytes" in message and "max_depth" in message  # the core's own words
    said = structure_cache.readable(message, {"max_depth": "Max depth", "leaf_size": "Leaf size"})
    assert "1 MiB" in said and "Max depth" in said and "max_depth" not in said and " bytes" not in said, said
    assert structure_cache.readable("needs about 4294967296 bytes, over the memory budget of 4294967296",
                                    {}) == "needs about 4 GiB, over the memory budget of 4 GiB"
