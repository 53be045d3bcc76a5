"""One render's statistics, declared once: the fields of raylab's render result (the core's counters,
read from api.COUNTER_INFO, and the renderer's own), their labels and how each is shown. The render
engine stores them, and the Last Render panels, the stats line and the comparison table show them.
No bpy import: draw() is handed a Blender layout."""
import numpy as np

from .. import api
from . import text_fit


def human_count(n):
    for limit, suffix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if n >= limit:
            return f"{n / limit:.{0 if n >= 100 * limit else 1}f}{suffix}"
    return f"{int(n)}"


def _short_number(value):
    """Two or three digits: "0.04", "4.6", "5", "46", "460"."""
    if value >= 9.95:
        return f"{value:.0f}"
    return f"{value:.1f}".removesuffix(".0") if value >= 0.995 else f"{value:.2g}"


def _in_units(value, units):
    """`value` in the first of `units` ((name, size, limit): the unit's size in the value's own, and the
    number from which the next unit is used) where it reads under that unit's limit."""
    for name, size, limit in units:
        text = _short_number(value / size)
        if limit is None or float(text) < limit:
            return f"{text} {name}"


def seconds_text(seconds):
    """A duration, short and readable: "0.4 ms", "32 ms", "4.6 s", "46 s", "7.5 min", "2.7 h"."""
    return _in_units(seconds, (("ms", 1e-3, 1000), ("s", 1.0, 60), ("min", 60.0, 60), ("h", 3600.0, None)))


def bytes_text(n):
    """A size in bytes, short: "512 B", "443 kB", "8.4 MB" (powers of 1000)."""
    return _in_units(n, (("B", 1, 1000), ("kB", 1e3, 1000), ("MB", 1e6, 1000), ("GB", 1e9, None)))


# The renderer's rays by kind; together they are the core's "rays" counter (every ray traced).
RAY_KINDS = (("rays_primary", "Primary rays"), ("rays_shadow", "Shadow rays"),
             ("rays_reflection", "Reflection rays"), ("rays_refraction", "Refraction rays"))

# (key, label, format) in the order they are shown: times, rays by kind, every core counter, memory.
FIELDS = ((("build_seconds", "Build", seconds_text),
           ("render_seconds", "Render", seconds_text))
          + tuple((key, label, human_count) for key, label in RAY_KINDS)
          + tuple((name, info["label"], human_count) for name, info in api.COUNTER_INFO.items())
          + (("memory_bytes", "Memory", bytes_text),))

# What a stored record (scene["raylab_last_render"], a comparison row) keeps of a render's stats.
KEYS = ("structure", "width", "height") + tuple(key for key, _, _ in FIELDS)

# A record estimated from a sample render (the same view at a few hundred pixels) holds the sample's pixel
# count under ESTIMATED_FROM. The sample builds the structure as the full render does, so its build time and
# memory are the structure's own (STRUCTURE_KEYS, measured), and the primary rays scaled by the ratio of
# pixels are the full image's exactly (its pixels times the samples per pixel); the render time and the
# other counts are the sample's times that ratio: estimates, shown after ESTIMATE_MARK.
ESTIMATED_FROM = "estimated_from"
STRUCTURE_KEYS = ("build_seconds", "memory_bytes")
MEASURED_IN_SAMPLE = STRUCTURE_KEYS + ("rays_primary",)
ESTIMATE_MARK = "~"

# ID properties hold 32-bit ints: larger counts are stored as floats.
_ID_INT_MAX = 2 ** 31 - 1


def scaled_to_image(sample, width, height):
    """A sample render's stats as the estimate of the same render at width x height (ESTIMATED_FROM)."""
    pixels = sample["width"] * sample["height"]
    ratio = width * height / pixels
    out = dict(sample, width=width, height=height, **{ESTIMATED_FROM: pixels})
    for key, _, _ in FIELDS:
        if key not in STRUCTURE_KEYS:
            out[key] = sample[key] * ratio if key == "render_seconds" else round(sample[key] * ratio)
    return out


def estimate_note(record):
    """The footnote of an estimated record's numbers."""
    return (f"{ESTIMATE_MARK} estimated from a {record[ESTIMATED_FROM]}-pixel sample of the same view, scaled "
            f"to {record['width']} x {record['height']} px; the values without {ESTIMATE_MARK} are measured")


def record(stats, super_sampling):
    """The render statistics as an ID-property dict (scene["raylab_last_render"], a comparison row);
    an estimate (scaled_to_image) keeps its ESTIMATED_FROM."""
    out = {"super_sampling": super_sampling}
    for key in KEYS + ((ESTIMATED_FROM,) if ESTIMATED_FROM in stats else ()):
        value = stats[key]
        if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
            value = int(value) if abs(int(value)) <= _ID_INT_MAX else float(value)
        elif not isinstance(value, str):
            value = float(value)
        out[key] = value
    return out


def size_text(record):
    return f"{record['width']} x {record['height']} px, super sampling {record['super_sampling']}"


def rows(record):
    """(label, text) for each field of a stored record, in FIELDS order (fields it lacks are left out);
    an estimated record's estimated values start with ESTIMATE_MARK."""
    estimated = ESTIMATED_FROM in record
    return [(label, (ESTIMATE_MARK if estimated and key not in MEASURED_IN_SAMPLE else "") + show(record[key]))
            for key, label, show in FIELDS if key in record]


def line(stats):
    """The one-line summary under the rendered image."""
    return (f"raylab {stats['structure']} | build {seconds_text(stats['build_seconds'])} | "
            f"render {seconds_text(stats['render_seconds'])} | {human_count(stats['rays'])} rays | "
            f"{human_count(stats['triangle_tests'])} triangle tests")


LAST_RENDER = "raylab_last_render"  # the scene's ID property holding the last F12's record
HEAT_SCALE = "heat_scale"  # a record's heat pass scale in words, when the render made one


def draw_last(layout, context):
    """The Last Render panels, in the Render Properties and in the viewport sidebar."""
    record = context.scene.get(LAST_RENDER)
    if record is None:
        text_fit.label(layout, context, "No raylab render yet (F12 with the raylab engine)")
    else:
        draw(layout, context, record)


def draw(layout, context, record):
    """Label rows for one stored record."""
    column = layout.column(align=True)
    text_fit.label(column, context, f"{record['structure']}, {size_text(record)}")
    for label, text in rows(record):
        split = column.split(factor=0.5)
        split.label(text=label)
        split.label(text=text)
    if HEAT_SCALE in record:
        text_fit.label(column, context, f"Heat: {record[HEAT_SCALE]}", 'INFO')
