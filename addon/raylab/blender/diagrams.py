"""The level diagrams in the Tutorial panel: each picture as wide as the panel, its caption wrapped under
it, and the full-size view one click away (Show Diagram).

A panel shows a picture only as a preview icon (UILayout.template_icon), drawn in a square: a picture of
another shape is fitted into the square with blank bands beside it. So every diagram is drawn as a column
of square tiles (tools/panel_figure.py), shown here as that many squares one under the other, each as wide
as the panel's column. Blender's own preview of a file is a thumbnail of at most 256 px, scaled again to
the square; these previews are made here from the picture's own pixels, resampled once to the size
Blender draws the square at, so it draws them pixel for pixel.
"""
import functools
import os

import bpy
import bpy.utils.previews
import numpy as np

from . import text_fit

PREVIEW_PAD = 4      # pixels Blender leaves on each side of a preview inside its square (interface_widgets)
CACHE_PICTURES = 12  # pictures kept in memory (a level shows at most six)

_previews = None
_pictures = {}       # path -> (H, W, 4) uint8, bottom row first (Blender's order), or the error loading it
_pending = set()     # (path, side) the next timer tick loads and tiles
_tiles = {}          # path -> (side in pixels, [icon id of each tile, top first])


def unit(context):
    """U.widget_unit in pixels: 18 units at the UI's scale, rounded in single precision as Blender does,
    plus a line's width either side (wm_window.c)."""
    system = context.preferences.system
    units = float(np.float32(18.0) * np.float32(system.ui_scale))
    return int(np.floor(units + 0.5)) + 2 * int(system.pixel_size)


def column_width(context):
    """The width of a panel's column in the sidebar, in pixels, as Blender lays it out: the region less
    the category tabs (a unit), the panels' margins (0.4 unit each side) and the panel's own padding
    (8 pixels at the UI's scale, each side). Measured against the drawn squares, tests/gui."""
    u = unit(context)
    panels = int(context.region.width - u - 0.8 * u)
    return panels - 2 * int(8.0 * context.preferences.system.ui_scale)


def preview_padding(context):
    """The pixels Blender leaves, both sides together, between a preview and its square's edges.
    3.4: 2 * PREVIEW_PAD (column 175 -> preview 167, 351 -> 343). 4.3 and 5.2 draw it otherwise;
    measured on the sidebar's screenshots (tests/gui): at system.ui_scale 1.0417 (view scale 1) 7 px
    (5.2: column 238 -> 231, 4.3: 237 -> 230), at 2.0833 (view scale 2) 13 px (5.2: 476 -> 463, 4.3:
    474 -> 461). int(6 * ui_scale + 1) gives both; a tile of that side is drawn pixel for pixel there."""
    if bpy.app.version < (4, 0, 0):
        return 2 * PREVIEW_PAD
    return int(6.0 * context.preferences.system.ui_scale + 1.0)


def tile_side(context):
    """The side of the square Blender draws a tile in: the column's width less the preview's padding."""
    return max(16, column_width(context) - preview_padding(context))


def _tag_redraw():
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == 'VIEW_3D':
                area.tag_redraw()


def _load_pending():
    """Reads the pictures the panel asked for and makes their tiles at the size it asked. A timer does it,
    not the panel's draw: reading a file and numpy's work on a picture let go of Python's interpreter
    lock, and a draw must not (see levels.available_levels); a draw also should leave the file's data
    alone: the image is only borrowed, removed again at once, and the file stays as it was."""
    for path, side in sorted(_pending):
        if path not in _pictures:
            _pictures[path] = _read_picture(path)
            while len(_pictures) > CACHE_PICTURES:
                _pictures.pop(next(iter(_pictures)))
        if not isinstance(_pictures[path], str):
            _make_tiles(path, side)
    _pending.clear()
    _tag_redraw()
    return None


def _read_picture(path):
    """(H, W, 4) uint8, bottom row first, or the error that kept it from loading."""
    try:
        image = bpy.data.images.load(path, check_existing=False)
    except RuntimeError as error:
        return str(error)
    try:
        width, height = image.size
        pixels = np.empty(width * height * 4, np.float32)
        image.pixels.foreach_get(pixels)
    finally:
        bpy.data.images.remove(image)
    return (pixels.reshape(height, width, 4) * 255.0 + 0.5).astype(np.uint8)


def _make_tiles(path, side):
    global _previews
    if _previews is None:
        _previews = bpy.utils.previews.new()
    for name in [n for n in _previews.keys() if n.startswith(path + "|")]:
        del _previews[name]  # the tiles of another width
    icons = []
    for k, square in enumerate(tiles(_pictures[path], side)):
        preview = _previews.new(f"{path}|{side}|{k}")
        preview.image_size = square.shape[1], square.shape[0]
        preview.image_pixels_float.foreach_set(square.ravel())
        icons.append(preview.icon_id)
    _tiles[path] = (side, icons)


def box_weights(size_in, size_out):
    """(size_out, size_in): each output pixel the mean of the input pixels it covers (area averaging, so
    a picture made smaller keeps its thin lines and its text instead of skipping pixels)."""
    edges = np.linspace(0.0, size_in, size_out + 1)
    first, last = edges[:-1, None], edges[1:, None]
    index = np.arange(size_in)[None, :]
    weights = np.clip(np.minimum(last, index + 1) - np.maximum(first, index), 0.0, None)
    return weights / weights.sum(axis=1, keepdims=True)


def tiles(picture, side):
    """The picture's square tiles, top first, each resampled to side x side (smaller or larger, by area):
    (side, side, 4) float32, bottom row first. A picture is as many squares tall as it is wide; a leftover
    strip is dropped."""
    height, width = picture.shape[:2]
    count = max(1, height // width)
    result = []
    for k in range(count):
        top = height - k * width  # rows count from the bottom
        square = picture[max(0, top - width):top].astype(np.float32) / 255.0
        if side != width:
            rows, cols = box_weights(square.shape[0], side), box_weights(width, side)
            square = np.tensordot(np.tensordot(rows, square, axes=(1, 0)), cols, axes=(1, 1)).transpose(0, 2, 1)
        result.append(np.ascontiguousarray(square, dtype=np.float32))
    return result


def tile_icons(context, path):
    """The icon ids of the diagram's tiles at the panel's current width, or None while it loads, or the
    error that kept it from loading. Called by a draw: it only asks a timer for what is missing."""
    picture = _pictures.get(path)
    if isinstance(picture, str):
        return picture
    # Always the square's own size, even above the picture's width (a wide sidebar, a large UI scale):
    # Blender fills the square with the preview whatever its size, so a smaller tile would only be
    # scaled again by Blender, blurred (Blender 5.x's sidebar at UI scale 2 is wider than the pictures).
    side = tile_side(context)
    made = _tiles.get(path)
    if made is not None and made[0] == side:
        return made[1]
    _pending.add((path, side))
    if not bpy.app.timers.is_registered(_load_pending):
        bpy.app.timers.register(_load_pending, first_interval=0.0)
    return None if made is None else made[1]  # the tiles of another width until these are made


def draw(layout, context, path, caption):
    """The diagram at `path` as wide as the panel, its caption wrapped under it, and Full Size."""
    icons = tile_icons(context, path)
    column = layout.column(align=True)
    if icons is None:
        column.label(text="Loading the diagram...", icon='IMAGE_DATA')
    elif isinstance(icons, str):
        text_fit.label(column, context, f"This diagram did not load: {icons}", 'ERROR')
    else:
        # The square's height is the column's width, so Blender draws the tile across the whole column;
        # the squares touch, the previews' padding between them. Half a pixel more against rounding:
        # the height is column_width whether Blender truncates it or rounds it. (A whole pixel more made
        # Blender 4.x/5.x draw the preview in a square of height - padding, one pixel wider than the
        # tile, so it rescaled it, blurred; 3.4 takes the smaller of the button's width and height.)
        scale = (column_width(context) + 0.5) / unit(context)
        for icon in icons:
            column.template_icon(icon_value=icon, scale=scale)
    if caption:
        text_fit.label(layout, context, caption)
    row = layout.row()
    row.alignment = 'RIGHT'
    row.operator(RAYLAB_OT_level_show_diagram.bl_idname, text="Full Size", icon='FULLSCREEN_ENTER').path = path


class RAYLAB_OT_level_show_diagram(bpy.types.Operator):
    """Show this diagram full size in a new window"""
    bl_idname = "raylab.level_show_diagram"
    bl_label = "Show Diagram"

    path: bpy.props.StringProperty(subtype="FILE_PATH", description="The diagram picture to show")

    def execute(self, context):
        if not os.path.isfile(self.path):
            self.report({'ERROR'}, f"raylab: no diagram at {self.path}")
            return {'CANCELLED'}
        image = bpy.data.images.load(self.path, check_existing=True)
        before = {w.as_pointer() for w in context.window_manager.windows}
        # render.view_show opens a new window with an image editor, sized for the render (351 x 302 in a
        # level: a cropped piece of a chart): sized for the diagram instead, then the diagram shown whole.
        render = context.scene.render
        saved = render.resolution_x, render.resolution_y, render.resolution_percentage
        width, height = full_size(tuple(image.size), (context.window.width, context.window.height))
        try:
            render.resolution_x, render.resolution_y, render.resolution_percentage = width, height, 100
            bpy.ops.render.view_show('INVOKE_DEFAULT')
        finally:
            render.resolution_x, render.resolution_y, render.resolution_percentage = saved
        window = next((w for w in context.window_manager.windows if w.as_pointer() not in before), None)
        windows = [window] if window is not None else list(context.window_manager.windows)
        area = next((a for w in windows for a in w.screen.areas if a.type == 'IMAGE_EDITOR'), None)
        if area is not None:
            area.spaces.active.image = image
            # Once the new window has its size: the whole diagram in view.
            bpy.app.timers.register(functools.partial(_fit_whole, area.as_pointer()), first_interval=0.2)
        return {'FINISHED'}


def full_size(image_size, window_size, margin=0.9):
    """The window size (width, height) that shows a diagram of `image_size` pixels at its full size, or
    as large as fits in `margin` of the main window keeping its shape."""
    width, height = image_size
    fit = min(1.0, margin * window_size[0] / max(width, 1), margin * window_size[1] / max(height, 1))
    return max(int(width * fit), 64), max(int(height * fit), 64)


def _fit_whole(pointer):
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.as_pointer() == pointer and area.type == 'IMAGE_EDITOR':
                region = next(r for r in area.regions if r.type == 'WINDOW')
                with bpy.context.temp_override(window=window, area=area, region=region):
                    bpy.ops.image.view_all(fit_view=True)
                return None
    return None


def release():
    """Frees the previews and the pictures (the add-on's unregister)."""
    global _previews
    if _previews is not None:
        bpy.utils.previews.remove(_previews)
        _previews = None
    _pictures.clear()
    _tiles.clear()
    _pending.clear()
