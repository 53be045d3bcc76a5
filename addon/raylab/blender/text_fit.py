"""Text that fits the region it is drawn in: every line raylab shows in a panel is wrapped at draw time to
the width Blender gives the label, measured with blf in the UI's own font and size, so Blender never elides
the middle of a line ("a rand... ray"). One function, `label`, draws a wrapped text; `lines` returns them.

The widths below are Blender's layout in units (UI_UNIT_X = 20 px at scale 1), measured on Blender 3.4, 4.3
and 5.2 in a window (the widest label each shows in full): a panel's margins with the sidebar's tab strip,
a box's margins, the icon of a label, and the padding Blender keeps either side of a label's text.
"""
import blf

UNIT = 20.0             # UI_UNIT_X at UI scale 1
PANEL_MARGIN = 1.3      # units: the region's edges and the panel's inner margins, together
# TABS: a sidebar's category tabs (UI_PANEL_CATEGORY_MARGIN_WIDTH); taken in every region: where there are
# none, text wraps a little early, never elided.
TABS = 1.0              # units
BOX_MARGIN = 0.4        # units a box (and each nested box) takes from the width
ICON = 1.2              # units an icon (or its BLANK1 stand-in) takes
TEXT_PADDING = 0.5      # units of padding Blender keeps around a label's text
LABEL_POINTS = 11.0     # the label font's size when the preferences have no style (at UI scale 1)

RECORD = None  # a list: every (line, measured_px, available_px) drawn is appended (the GUI tests read it)
_cache = {}


def scale(context):
    """The UI's pixel scale (the resolution scale times the display's DPI factor; in background mode, where
    Blender has no display, the resolution scale)."""
    return context.preferences.system.ui_scale or context.preferences.view.ui_scale


def font_pixels(context):
    styles = context.preferences.ui_styles
    style = getattr(styles[0], "widget_label", None) or getattr(styles[0], "widget", None) if len(styles) else None
    points = style.points if style is not None else LABEL_POINTS
    return points * scale(context)


def measure(text, pixels):
    """The width in pixels of `text` in the UI font at `pixels` size; a character estimate when blf has no
    font (Blender in background mode)."""
    blf.size(0, pixels)
    width = blf.dimensions(0, text)[0]
    return width if width > 0 or not text.strip() else 0.55 * pixels * len(text)


def panel_width(context, width=None):
    """The pixels a panel's layout gets in the current region (or a region `width` wide)."""
    region_width = width if width is not None else context.region.width
    return region_width - UNIT * scale(context) * (PANEL_MARGIN + TABS)


def available(context, icon=False, boxes=0, columns=1, width=None):
    """The pixels a label's text gets in the current region: the panel's width less the boxes' margins,
    split into `columns`, less the icon and the text's padding."""
    s = scale(context)
    inner = (panel_width(context, width) - UNIT * s * BOX_MARGIN * boxes) / max(1, columns)
    return inner - UNIT * s * ((ICON if icon else 0.0) + TEXT_PADDING)


def fits(context, text, icon=False, boxes=0, columns=1, width=None):
    """True if `text` fits on one line (a button's text cannot wrap)."""
    return measure(text, font_pixels(context)) <= available(context, icon, boxes, columns, width)


# Where a word wider than the line may break, keeping the mark on the first line: a name such as
# moller_trumbore or a path breaks after "_" or "/" ("moller_" / "trumbore"), never mid-word if it can.
BREAK_AFTER = "_/.-,"


def lines(context, text, icon=False, boxes=0, columns=1, width=None):
    """`text` broken into lines that each fit: at spaces where it can, inside a word only when one word is
    wider than the line, then after one of BREAK_AFTER if a piece up to one fits."""
    room = max(1.0, available(context, icon, boxes, columns, width))
    pixels = font_pixels(context)
    key = (text, round(room), round(pixels, 2))
    if key in _cache:
        return _cache[key]
    if len(_cache) > 4096:
        _cache.clear()
    result = []
    for paragraph in text.split("\n"):
        line = ""
        for word in paragraph.split(" "):
            candidate = f"{line} {word}" if line else word
            if measure(candidate, pixels) <= room:
                line = candidate
                continue
            if line:
                result.append(line)
            line = word
            while measure(line, pixels) > room and len(line) > 1:  # one word wider than the line
                cut = next(n for n in range(len(line) - 1, 0, -1) if measure(line[:n], pixels) <= room or n == 1)
                marks = [n for n in range(1, cut + 1) if line[n - 1] in BREAK_AFTER]
                cut = marks[-1] if marks else cut
                result.append(line[:cut])
                line = line[cut:]
        result.append(line)
    _cache[key] = result
    return result


def label(layout, context, text, icon='NONE', boxes=0, columns=1, scale_y=0.8, width=None):
    """Draws `text` wrapped to the region as an aligned column of labels; the first line carries the icon
    and the following lines an empty icon, so the text stays aligned."""
    column = layout.column(align=True)
    column.scale_y = scale_y
    has_icon = icon != 'NONE'
    fitted = lines(context, text, has_icon, boxes, columns, width)
    for i, line in enumerate(fitted):
        column.label(text=line, icon=(icon if i == 0 else 'BLANK1') if has_icon else 'NONE')
        if RECORD is not None:
            RECORD.append((line, measure(line, font_pixels(context)),
                           available(context, has_icon, boxes, columns, width)))
    return column
