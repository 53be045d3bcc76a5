"""Runs inside a real Blender window (xvfb-run): opens levels and scrolls the sidebar's raylab tab down
until a diagram of the Tutorial panel is in view, then takes a window screenshot.

    xvfb-run -a -s "-screen 0 1600x900x24" blender --factory-startup START.blend \
        --python tests/gui/diagrams_session.py -- OUT_DIR LEVEL_ID/DIAGRAM.png[@UI_SCALE] [...]

For every diagram: OUT_DIR/diagram_LEVEL_ID_DIAGRAM.png (the window) and OUT_DIR/diagram_..._tileK.png
(each tile as the add-on handed it to Blender). OUT_DIR/diagrams_session.json holds, per diagram, the
sidebar's rectangle in the window, where its tiles were found in the sidebar (as many as it holds), the
column's width the add-on computed, the UI scale and the caption's lines as they were drawn; for the
last one also what Full Size opened; or "error".
"""
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import call_in_main_window, click_raylab_tab, screenshot, show_sidebar, view3d  # noqa: E402
from session import ROOT, rect, sidebar_pixels  # noqa: E402

OUT_DIR, TARGETS = session.out_dir(), session.ARGS[1:]
report = {"diagrams": {}}
SESSION = session.Session(os.path.join(OUT_DIR, "diagrams_session.json"), report)
looks = [0]  # every look, for the watchdog: scrolling is progress too
WATCHDOG_SECONDS = 240
SCROLL_TRIES = 80

import raylab  # noqa: E402
from raylab.blender import diagrams, levels, text_fit  # noqa: E402


def find_tiles(pixels, expected, needed):
    """[(difference, row, col)] of the top-left corner of the first `needed` expected tiles (top first,
    (side, side, 3) floats, top row first) where the sidebar shows them, or None unless they are all in
    view. A tile's top row is white (a diagram's margin) under the panel's darker background."""
    side = expected[0].shape[0]
    white = pixels.min(axis=-1) > 0.9
    counts = white.sum(axis=1)
    tops = [r for r in range(1, pixels.shape[0] - side + 1) if counts[r] > 0.9 * side and counts[r - 1] < 0.5 * side]
    found = []
    for tile in expected[:needed]:
        best = None
        for row in [r for r in tops if not found or r >= found[-1][1] + side]:  # each under the one before
            left = int(np.flatnonzero(white[row]).min())
            for col in range(max(0, left - 2), min(left + 3, pixels.shape[1] - side + 1)):
                diff = float(np.abs(pixels[row:row + side, col:col + side] - tile).mean())
                if best is None or diff < best[0]:
                    best = (diff, row, col)
        if best is None or best[0] > 0.03:
            return None
        found.append(best)
    return found


def region_context():
    window, area, _, sidebar = view3d()
    return bpy.context.temp_override(window=window, area=area, region=sidebar)


def steps_for(target, first):
    where, _, scale = target.partition("@")
    level_id, name = where.split("/")
    path = os.path.join(ROOT, "levels", level_id, "diagrams", name)
    key = f"{level_id}_{os.path.splitext(name)[0]}" + (f"_scale{scale}" if scale else "")
    state = {"tries": 0}

    def open_level():
        levels.open_level(bpy.context, level_id)
        bpy.context.scene.raylab.spin = False
        show_sidebar()

    def to_top():
        # After the tab is clicked (3.4 has no API for it, and the click's place depends on the scale).
        bpy.context.preferences.view.ui_scale = float(scale or 1.0)
        with region_context():
            for _ in range(200):
                bpy.ops.view2d.scroll_up()

    def look():
        """Scrolls a little at a time (a step per redraw) until the diagram's tiles are in view: all of
        them, or as many as the sidebar can hold."""
        looks[0] += 1
        made = diagrams._tiles.get(path)
        with region_context():
            side_now = diagrams.tile_side(bpy.context)
        if made is not None and made[0] != side_now:
            # The panel shows the tiles of the width before until a timer has made these (the draw asks
            # for them; it does not make them): wait for that.
            state["tries"] += 1
            if state["tries"] > SCROLL_TRIES:
                gave_up(made)
                raise RuntimeError(f"{target}: the tiles of {side_now} px were never made (still {made[0]} px)")
            STEPS.insert(0, look)
            return
        calls = 1
        if made is not None:
            side = made[0]
            expected = [np.asarray(t[::-1, :, :3]) for t in diagrams.tiles(diagrams._pictures[path], side)]
            _, _, _, sidebar = view3d()
            needed = min(len(expected), 3, sidebar.height // (side + 2 * diagrams.PREVIEW_PAD))
            found = find_tiles(sidebar_pixels(), expected, needed)
            if found is not None:
                shoot(made, expected, found)
                return
            # A scroll moves 40 pixels (Blender's view2d.scroll_down): steps of under half the room the
            # tiles leave in the sidebar cannot jump past the place where they are all in view.
            calls = max(1, (sidebar.height - needed * (side + 2 * diagrams.PREVIEW_PAD + 1)) // 80)
        state["tries"] += 1
        if state["tries"] > SCROLL_TRIES:
            gave_up(made)
            raise RuntimeError(f"{target}: the diagram never came into view (the sidebar as last seen: "
                               f"{os.path.join(OUT_DIR, f'gave_up_{key}.png')})")
        with region_context():
            for _ in range(calls):
                bpy.ops.view2d.scroll_down()
        STEPS.insert(0, look)

    def gave_up(made):
        """The sidebar as it was last seen, and what the add-on computed, for the one who reads why."""
        from matplotlib import image as mpimg
        _, _, _, sidebar = view3d()
        mpimg.imsave(os.path.join(OUT_DIR, f"gave_up_{key}.png"), sidebar_pixels())
        with region_context():
            computed = dict(column_width=diagrams.column_width(bpy.context), unit=diagrams.unit(bpy.context),
                            tile_side=diagrams.tile_side(bpy.context))
        report.setdefault("gave_up", {})[target] = dict(
            computed, side=None if made is None else made[0], ui_scale=bpy.context.preferences.system.ui_scale,
            pixel_size=bpy.context.preferences.system.pixel_size, view_ui_scale=bpy.context.preferences.view.ui_scale,
            sidebar=rect(sidebar))
        if made is not None:
            for k, tile in enumerate(diagrams.tiles(diagrams._pictures[path], made[0])):
                mpimg.imsave(os.path.join(OUT_DIR, f"gave_up_{key}_tile{k}.png"), np.asarray(tile[::-1, :, :3]))

    def shoot(made, expected, found):
        from matplotlib import image as mpimg
        window, _, _, sidebar = view3d()
        caption = next(b[2] for b in levels.find_level(level_id).blocks if b[0] == "image" and b[1] == path)
        text_fit.RECORD = []  # the lines the screenshot's redraw draws
        screenshot(os.path.join(OUT_DIR, f"diagram_{key}.png"))
        drawn, text_fit.RECORD = text_fit.RECORD, None
        for k, tile in enumerate(expected):
            mpimg.imsave(os.path.join(OUT_DIR, f"diagram_{key}_tile{k}.png"), tile)
        with region_context():
            column_width, unit = diagrams.column_width(bpy.context), diagrams.unit(bpy.context)
            # A label's text gets the column less Blender's padding around it (text_fit's measure of it).
            label_room = column_width - text_fit.UNIT * text_fit.scale(bpy.context) * text_fit.TEXT_PADDING
        report["diagrams"][target] = dict(
            key=key, window_height=window.height,
            sidebar=rect(sidebar),
            tiles=[dict(row=r, col=c, difference=d) for d, r, c in found], tile_count=len(expected), side=made[0],
            column_width=column_width, label_room=label_room, unit=unit, blender_version=list(bpy.app.version),
            padding=diagrams.preview_padding(bpy.context),
            ui_scale=bpy.context.preferences.system.ui_scale,
            tries=state["tries"], caption=caption,
            # The panel is drawn twice for the screenshot: its lines once each.
            caption_lines=list(dict.fromkeys((line, measured, room) for line, measured, room in drawn
                                             if line and line in caption)))

    def show_full_size():
        """Full Size, as its button runs it: the diagram in an image editor in a new window."""
        bpy.context.preferences.view.ui_scale = 1.0
        windows = len(bpy.context.window_manager.windows)
        call_in_main_window(bpy.ops.raylab.level_show_diagram, path=path)
        report["diagrams"][target]["windows_before_full_size"] = windows

    def full_size_shown():
        wm = bpy.context.window_manager
        editors = [(w, a) for w in wm.windows for a in w.screen.areas
                   if a.type == 'IMAGE_EDITOR' and a.spaces.active.image is not None]
        shown = [a.spaces.active.image.filepath for _, a in editors]
        # The new window's size and how much of the diagram its editor shows (zoom x image over the region),
        # once its editor has zoomed to fit (the operator's timer), or after the tries run out.
        window, area = editors[-1]
        region = next(r for r in area.regions if r.type == 'WINDOW')
        space = area.spaces.active
        state["fit_tries"] = state.get("fit_tries", 0) + 1
        fitted = all(space.zoom[i] * space.image.size[i] <= (region.width, region.height)[i] + 1 for i in (0, 1))
        if not fitted and state["fit_tries"] < 20:
            return False
        report["diagrams"][target].update(windows_after_full_size=len(wm.windows), full_size_images=shown,
                                          full_size_window=[window.width, window.height],
                                          full_size_region=[region.width, region.height],
                                          full_size_zoom=list(space.zoom), full_size_image=list(space.image.size),
                                          main_window=[wm.windows[0].width, wm.windows[0].height])

    steps = [open_level] + ([click_raylab_tab] if first else []) + [to_top, look]
    return steps + ([show_full_size, full_size_shown] if target == TARGETS[-1] else [])


STEPS = [step for i, target in enumerate(TARGETS) for step in steps_for(target, i == 0)]

SESSION.run(STEPS, raylab.register, interval=0.5, watchdog_seconds=WATCHDOG_SECONDS,
            progress=lambda: (len(STEPS), looks[0]))
