"""One render's statistics, declared once: the fields of raylab's render result (the core's counters,
read from api.COUNTER_INFO, and the renderer's own), their labels and how each is shown. The render
engine stores them, and the Last Render panels, the stats line and the comparison table show them.
No bpy import: draw() is handed a Blender layout."""
import numpy as np

from .. import api


def human_count(n):
    for limit, suffix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if n >= limit:
            return f"{n / limit:.{0 if n >= 100 * limit else 1}f}{suffix}"
    return f"{int(n)}"


# The renderer's rays by kind; together they are the core's "rays" counter (every ray traced).
RAY_KINDS = (("rays_primary", "Primary rays"), ("rays_shadow", "Shadow rays"),
             ("rays_reflection", "Reflection rays"), ("rays_refraction", "Refraction rays"))

# (key, label, format) in the order they are shown: times, rays by kind, every core counter, memory.
FIELDS = ((("build_seconds", "Build", lambda v: f"{1000 * v:.1f} ms"),
           ("render_seconds", "Render", lambda v: f"{v:.2f} s"))
          + tuple((key, label, human_count) for key, label in RAY_KINDS)
          + tuple((name, info["label"], human_count) for name, info in api.COUNTER_INFO.items())
          + (("memory_bytes", "Memory", lambda v: f"{v / 1024:.1f} KiB"),))

# What a stored record (scene["raylab_last_render"], a comparison row) keeps of a render's stats.
KEYS = ("structure", "width", "height") + tuple(key for key, _, _ in FIELDS)

# ID properties hold 32-bit ints: larger counts are stored as floats.
_ID_INT_MAX = 2 ** 31 - 1


def record(stats, super_sampling):
    """The render statistics as an ID-property dict (scene["raylab_last_render"])."""
    out = {"super_sampling": super_sampling}
    for key in KEYS:
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
    """(label, text) for each field of a stored record, in FIELDS order (fields it lacks are left out)."""
    return [(label, show(record[key])) for key, label, show in FIELDS if key in record]


def line(stats):
    """The one-line summary under the rendered image."""
    return (f"raylab {stats['structure']} | build {stats['build_seconds']:.3f} s | "
            f"render {stats['render_seconds']:.2f} s | {human_count(stats['rays'])} rays | "
            f"{human_count(stats['triangle_tests'])} triangle tests")


LAST_RENDER = "raylab_last_render"  # the scene's ID property holding the last F12's record
HEAT_SCALE = "heat_scale"  # a record's heat pass scale in words, when the render made one


def draw_last(layout, scene):
    """The Last Render panels, in the Render Properties and in the viewport sidebar."""
    record = scene.get(LAST_RENDER)
    if record is None:
        layout.label(text="No raylab render yet (F12 with the raylab engine)")
    else:
        draw(layout, record)


def draw(layout, record):
    """Label rows for one stored record."""
    column = layout.column(align=True)
    column.label(text=f"{record['structure']}, {size_text(record)}")
    for label, text in rows(record):
        split = column.split(factor=0.5)
        split.label(text=label)
        split.label(text=text)
    if HEAT_SCALE in record:
        column.label(text=f"Heat: {record[HEAT_SCALE]}", icon='INFO')
