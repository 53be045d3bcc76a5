"""The top bar stays after F12, closing the render window and opening a level (issue 40, item 5): Blender
3.4 blanks a window's top bar once its scene has a name of 16 or more characters after a render window was
opened and closed (with Workbench and no add-on too: a rename is enough), and raylab's level scenes have
such names ("raylab: AABB 1: ..."); it came back only when the workspace was switched.

Runs tests/gui/top_bar_session.py; out/gui/top_bar_before.png and top_bar_after.png show the window."""
import os

import numpy as np

from gui_util import OUT, load_rgb, run_session, start_blend

TOP_BAR_HEIGHT = 26  # pixels at the window's top (1600x900, scale 1)
MENUS_AND_TABS = slice(0, 700)  # File Edit Render Window Help, then the workspace tabs; the scene's name is right


def test_the_top_bar_stays_after_f12_closing_the_render_window_and_a_level_switch(tmp_path):
    report = run_session("top_bar_session.py", "top_bar.json", start_blend(tmp_path), ["aabb_1"],
                         outputs=["top_bar_before.png", "top_bar_after.png"])
    assert report["windows"] == {"before": 1, "rendered": 2, "after": 1}  # the render window opened, then closed
    assert report["workspace"]["after"] == report["workspace"]["before"]
    assert report["areas"]["after"] == report["areas"]["before"], "the level switch changed the window's areas"
    before, after = (load_rgb(os.path.join(OUT, f"top_bar_{when}.png"))[:TOP_BAR_HEIGHT, MENUS_AND_TABS]
                     for when in ("before", "after"))
    assert before.std() > 0.05, "no top bar before F12: the screenshot is not of the window"
    # The same menus and tabs, drawn (an empty top bar is one flat colour)
    assert after.std() > 0.05, f"the top bar is empty after the level switch (pixel spread {after.std():.3f})"
    assert np.abs(after - before).mean() < 0.02, "the top bar's menus and tabs differ after the level switch"
