"""Runs inside a real Blender window (xvfb-run, --enable-event-simulate for 3.4's sidebar tab): the Why SAH?
level with the tree view on, Costliest pressed once from the root (an inner node: the Split Explorer charts
its splits), the sidebar on the raylab tab; one window screenshot and a JSON with the viewport region's
place, what the explorer's chart labels say where (tree_view.chart_layout) and which sidebar panels draw,
in their order (session.PanelDraws).

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup --enable-event-simulate \
        --python tests/gui/why_sah_shot.py -- OUT_DIR

Writes OUT_DIR/why_sah_tree.png and why_sah.json ("error" in it if anything failed).
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
import raylab  # noqa: E402
from blender_window import call_in_main_window, click_raylab_tab, screenshot, show_sidebar, view3d  # noqa: E402
from raylab.blender import text_fit, tree_view  # noqa: E402

OUT = session.out_dir()
report = {}
SESSION = session.Session(os.path.join(OUT, "why_sah.json"), report)
seen = {}


def set_up():
    raylab.register()
    text_fit.RECORD = []  # every panel line drawn: the picked node's among them
    seen["panels"] = session.PanelDraws()


def open_level():
    assert call_in_main_window(bpy.ops.raylab.level_open, level_id="why_sah") == {'FINISHED'}


def sidebar():
    show_sidebar()  # once the window has drawn the level's scene


def tree_on():
    bpy.context.window.scene.raylab_tree.enabled = True
    view3d()[2].tag_redraw()


def tree_drawn():
    """Waits until the tree view has drawn in the viewport (a draw takes up to seconds here)."""
    if view3d()[2].as_pointer() not in tree_view._shown:
        return False
    assert call_in_main_window(bpy.ops.raylab.tree_walk, step='ROOT') == {'FINISHED'}
    assert call_in_main_window(bpy.ops.raylab.tree_walk, step='COSTLIEST') == {'FINISHED'}
    seen["drawn"] = tree_view._shown[view3d()[2].as_pointer()]
    view3d()[2].tag_redraw()
    return None


def picked_drawn():
    """Waits for a draw after the pick (each draw stores a new tuple), then one more tick to be shown."""
    region = view3d()[2]
    if tree_view._shown.get(region.as_pointer()) is seen["drawn"]:
        return False
    scene = bpy.context.window.scene
    tree = tree_view._last_read[scene.name_full]
    node = tree_view.picked(scene, tree)[0]
    splits = tree.known_splits(node)
    assert splits is not None, "no split computed for the picked node"
    _, chart = tree_view.frames(region)
    plot, (low, high), _, _, labels = tree_view.chart_layout(chart, splits)
    report.update(region=session.rect(region), chart=list(chart), plot=list(plot), node=int(node),
                  labels=[dict(x=x, y=y, text=text, colour=list(colour)) for x, y, text, colour in labels],
                  blender=bpy.app.version_string)
    return None


def raylab_tab():
    click_raylab_tab()  # now that the sidebar has drawn: its tabs are where the click goes
    sidebar = view3d()[3]
    report["sidebar"] = session.rect(sidebar)


def shot():
    screenshot(os.path.join(OUT, "why_sah_tree.png"))
    report["panel_lines"] = list(dict.fromkeys(line for line, _, _ in text_fit.RECORD))
    report["panels_drawn"] = seen["panels"].last_redraw()


SESSION.run([open_level, sidebar, raylab_tab, tree_on, tree_drawn, picked_drawn, shot], set_up, watchdog_seconds=120)
