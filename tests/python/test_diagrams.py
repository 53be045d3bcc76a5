"""Every diagram a level shows can be read in the sidebar's Tutorial panel (issue 27, item 6): at
Blender's default sidebar width a diagram is shown PANEL_TILE_PX wide (tests/gui/test_diagrams_gui.py
measures that in a real window), and there every text of it is at least MIN_TEXT_PX tall (its font's
em), lies whole inside one of the diagram's squares and inside the picture, and covers no other text.

The measurements are the ones tools/panel_figure.py wrote into each PNG as it drew it (its texts'
sizes and boxes as matplotlib drew them), so they belong to the very picture that ships.
"""
import json
import pathlib
import sys

import pytest
from PIL import Image

# The checkout's levels and tools (the add-on package may be a copy elsewhere: ./raylab test --sanitize).
ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from raylab.blender import levels  # noqa: E402
from tools import panel_figure  # noqa: E402

DIAGRAMS = sorted({block[1] for level in levels.available_levels(str(ROOT / "levels"))[0] for block in level.blocks
                   if block[0] == "image"})
SHRINK = panel_figure.PANEL_TILE_PX / panel_figure.TILE_PX  # drawn pixels to panel pixels


def name(path):
    return "/".join(path.split("/")[-3::2])


def measured(path):
    image = Image.open(path)
    assert panel_figure.METADATA_KEY in image.text, f"{name(path)} was not drawn by tools/panel_figure.py"
    return image.size, json.loads(image.text[panel_figure.METADATA_KEY])


def test_every_level_shows_diagrams():
    assert len(DIAGRAMS) >= 20


@pytest.mark.parametrize("path", DIAGRAMS, ids=name)
def test_the_diagram_is_a_column_of_squares_drawn_for_the_panel(path):
    (width, height), record = measured(path)
    assert width == panel_figure.TILE_PX == record["tile_px"]
    assert height == record["tiles"] * width, "the panel shows a diagram as whole squares"
    assert 1 <= record["tiles"] <= 4


@pytest.mark.parametrize("path", DIAGRAMS, ids=name)
def test_every_text_is_large_enough_at_the_panel_width(path):
    _, record = measured(path)
    assert record["texts"], f"{name(path)} has no text"
    small = [(t["text"], round(t["px"] * SHRINK, 1)) for t in record["texts"]
             if t["px"] * SHRINK < panel_figure.MIN_TEXT_PX]
    assert not small, f"texts under {panel_figure.MIN_TEXT_PX} px in the panel: {small}"
    # Mathtext draws exponents and indices smaller than its font: none may be used.
    assert not [t["text"] for t in record["texts"] if t["mathtext"]]


@pytest.mark.parametrize("path", DIAGRAMS, ids=name)
def test_every_text_lies_whole_in_one_square(path):
    (width, height), record = measured(path)
    side = record["tile_px"]
    for t in record["texts"]:
        x0, y0, x1, y1 = t["box"]
        assert 0 <= x0 and x1 <= width and 0 <= y0 and y1 <= height, f"{t['text']!r} is cut by the picture's edge"
        assert int(y0 // side) == int((y1 - 1e-6) // side), f"{t['text']!r} crosses from one square into the next"


@pytest.mark.parametrize("path", DIAGRAMS, ids=name)
def test_no_text_covers_another(path):
    _, record = measured(path)
    texts = record["texts"]
    for i, a in enumerate(texts):
        for b in texts[i + 1:]:
            overlap_x = min(a["box"][2], b["box"][2]) - max(a["box"][0], b["box"][0])
            overlap_y = min(a["box"][3], b["box"][3]) - max(a["box"][1], b["box"][1])
            assert overlap_x <= 1 or overlap_y <= 1, f"{a['text']!r} and {b['text']!r} overlap"
