"""Why SAH? in a real Blender window under Xvfb (issue 42 items 2 and 5): the Split Explorer's chart is
drawn with its unit, the costs at the ends of its axis, where across the box a split lies and a legend,
each label's text in its colour where chart_layout puts it. Runs why_sah_shot.py; the screenshot lands in
out/gui/why_sah_tree.png."""
import os

import numpy as np
import pytest

import gui_util

TEXT_WIDTH = 7.0  # tree_view.TEXT_WIDTH: a character of the chart's 12 px font, at most
TEXT_HEIGHT = 12


@pytest.fixture(scope="module")
def why_sah_shot(tmp_path_factory):
    # A saved file, not factory startup's splash screen: that took the click on the raylab tab.
    report = gui_util.run_session("why_sah_shot.py", "why_sah.json",
                                  gui_util.start_blend(tmp_path_factory.mktemp("why_sah")),
                                  outputs=("why_sah_tree.png",), extra=("--enable-event-simulate",))
    image = gui_util.load_rgb(os.path.join(gui_util.OUT, "why_sah_tree.png"))
    region = gui_util.Region(report["region"], image.shape[0])
    return report, region, region.crop(image)


def test_the_split_explorer_draws_its_labels_in_their_colours(why_sah_shot):
    report, region, image = why_sah_shot
    texts = [label["text"] for label in report["labels"]]
    assert any("triangle tests" in text for text in texts) and "0%" in texts and "100% across" in texts
    assert {"x", "y", "z", "leaf"} <= set(texts)
    for label in report["labels"]:
        top, left = region.row_col(label["x"], label["y"] + TEXT_HEIGHT + 2)
        box = image[max(top, 0):top + TEXT_HEIGHT + 6, left:left + int(TEXT_WIDTH * len(label["text"])) + 2]
        inked = gui_util.color_mask(box, label["colour"], tolerance=0.25)
        assert inked.sum() >= 3 * len(label["text"].replace(" ", "")), (label, int(inked.sum()))


def test_the_chart_s_plot_holds_the_three_axes_curves(why_sah_shot):
    report, region, image = why_sah_shot
    x, y, width, height = report["plot"]
    top, left = region.row_col(x, y + height)
    plot = image[top:top + height, left:left + width]
    for colour in ((1.0, 0.2, 0.2), (0.4, 1.0, 0.4), (0.25, 0.4, 1.0)):
        assert gui_util.color_mask(plot, colour, tolerance=0.25).sum() > 30, colour
    assert np.isfinite(plot).all()


def test_the_tree_panel_is_open_right_under_the_tasks(why_sah_shot):
    """Issue 42 item 5: the Tree panel was closed at the sidebar's bottom. In Why SAH? it stands open right
    under the level's Tasks (Blender draws an open panel's content, in the sidebar's order), once, with the
    picked node's lines in the unit of the SAH cost."""
    report, _, _ = why_sah_shot
    drawn = report["panels_drawn"]
    assert "Tasks" in drawn and drawn[drawn.index("Tasks") + 1:][:1] == ["Tree"], drawn
    assert drawn.count("Tree") == 1, drawn
    lines = report["panel_lines"]
    assert any(line.startswith(f"Node {report['node']}: depth") for line in lines), lines
    assert "SAH cost here and below" in " ".join(lines), lines
