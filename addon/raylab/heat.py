"""False colour for per-pixel counts (render(...).cost, Hits.per_ray): one fixed colour map and a fixed,
stated scale, so that two images made with the same maximum compare colour for colour: the same colour
is the same count, whatever structure made it. numpy only.

    heat = raylab.heat_map(result.cost["triangle_tests"], maximum=200)   # (H, W, 4) linear RGBA
    legend = raylab.heat_legend(200, width=heat.shape[1])                 # the colour bar with its numbers
    raylab.write_image("heat.png", np.concatenate([heat, legend]))
    raylab.heat_scale_text("Triangle tests", 200)                         # the scale in words

Several structures side by side on one scale (what "Where does the work go?" shows):

    maps = [raylab.heat_map(raylab.render(scene_with(s), camera, lights, materials).cost["triangle_tests"], 200)
            for s in ("none", "aabb", "octree", "bvh")]
    strip = np.concatenate(maps, axis=1)
    picture = np.concatenate([strip, raylab.heat_legend(200, width=strip.shape[1])])

The images are linear RGBA, as render() makes them (write_image and Blender's Standard view transform
show the colour map as it is meant; Filmic or AgX would bend it).
"""
import math

import numpy as np

# The colour map, declared once: inferno (matplotlib's, perceptually uniform, readable in grey) at nine
# evenly spaced stops, display sRGB. 0 is near black, the maximum pale yellow.
HEAT_COLOURS = np.array([
    (0.001, 0.000, 0.014), (0.087, 0.045, 0.225), (0.258, 0.039, 0.406),
    (0.416, 0.090, 0.433), (0.578, 0.148, 0.404), (0.736, 0.216, 0.330),
    (0.865, 0.317, 0.226), (0.955, 0.469, 0.100), (0.988, 0.998, 0.645)], np.float32)
HEAT_COLOUR_NAMES = ("black", "pale yellow")  # the two ends, for the scale in words


def _srgb_to_linear(c):
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def _check_maximum(maximum):
    if isinstance(maximum, bool) or not isinstance(maximum, (int, float, np.integer, np.floating)):
        raise ValueError(f"maximum must be a positive number, got {maximum!r}")
    if not (math.isfinite(maximum) and maximum > 0):
        raise ValueError(f"maximum must be finite and > 0, got {maximum!r}")
    return float(maximum)


def heat_map(values, maximum):
    """(H, W) counts -> (H, W, 4) float32 linear RGBA in the fixed colour map (HEAT_COLOURS), on the
    fixed scale [0, maximum]: 0 is the first colour, `maximum` and anything above it the last, values
    in between interpolated linearly. Any array shape works ((N,) gives (N, 4)). ValueError for a
    maximum that is not a finite positive number or values that are not finite real numbers."""
    top = _check_maximum(maximum)
    v = np.asarray(values)
    if v.dtype.kind not in "fiub":
        raise ValueError(f"values must be real numbers, got dtype {v.dtype}")
    v = v.astype(np.float64)
    if not np.isfinite(v).all():
        raise ValueError("values must be finite (a NaN or infinite count has no colour)")
    position = np.clip(v / top, 0.0, 1.0) * (len(HEAT_COLOURS) - 1)
    low = np.minimum(position.astype(np.int64), len(HEAT_COLOURS) - 2)
    t = (position - low)[..., None]
    srgb = (1.0 - t) * HEAT_COLOURS[low] + t * HEAT_COLOURS[low + 1]
    out = np.ones(v.shape + (4,), np.float32)
    out[..., :3] = _srgb_to_linear(srgb.astype(np.float32))
    return out


def heat_ticks(maximum):
    """The legend's numbers: [(value, text)] at 0, the middle and the maximum ("+": and above)."""
    top = _check_maximum(maximum)
    return [(0.0, "0"), (top / 2, _short(top / 2)), (top, _short(top) + "+")]


def heat_scale_text(label, maximum):
    """The scale in words, for a stats line or a panel: "Triangle tests per pixel: 0 (black) to 200+
    (pale yellow), inferno"."""
    ticks = heat_ticks(maximum)
    return (f"{label} per pixel: {ticks[0][1]} ({HEAT_COLOUR_NAMES[0]}) to {ticks[-1][1]} "
            f"({HEAT_COLOUR_NAMES[1]}), inferno")


def _short(value):
    """A number in at most four characters and a suffix: 0.5, 12, 250, 1.5k, 20M."""
    for limit, suffix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if value >= limit:
            return _digits(value / limit) + suffix
    return _digits(value)


def _digits(x):
    text = f"{x:.3g}"
    return f"{x:.0f}" if "e" in text else text


# A 3 x 5 pixel font for the legend's numbers: rows top to bottom, "1" is ink.
_GLYPHS = {
    "0": ("111", "101", "101", "101", "111"), "1": ("010", "110", "010", "010", "111"),
    "2": ("111", "001", "111", "100", "111"), "3": ("111", "001", "111", "001", "111"),
    "4": ("101", "101", "111", "001", "001"), "5": ("111", "100", "111", "001", "111"),
    "6": ("111", "100", "111", "101", "111"), "7": ("111", "001", "001", "010", "010"),
    "8": ("111", "101", "111", "101", "111"), "9": ("111", "101", "111", "001", "111"),
    ".": ("000", "000", "000", "000", "010"), "+": ("000", "010", "111", "010", "000"),
    "k": ("100", "101", "110", "101", "101"), "M": ("101", "111", "111", "101", "101"),
    "G": ("111", "100", "101", "101", "111"),
}
_SCALE = 2                       # font pixels per glyph pixel
_GLYPH_W, _GLYPH_H = 4 * _SCALE, 5 * _SCALE   # with one column of spacing
LEGEND_TEXT_HEIGHT = _GLYPH_H + 4   # the number row under the colour bar


def _text_mask(text):
    mask = np.zeros((_GLYPH_H, _GLYPH_W * len(text)), bool)
    for i, ch in enumerate(text):
        glyph = np.array([[c == "1" for c in row] for row in _GLYPHS[ch]])
        block = np.kron(glyph, np.ones((_SCALE, _SCALE), bool))
        mask[:, i * _GLYPH_W:i * _GLYPH_W + 3 * _SCALE] = block
    return mask


def heat_legend(maximum, width=256, bar_height=12):
    """The legend of heat_map(..., maximum) as an image to show beside or under a heat map: a colour
    bar from 0 (left) to `maximum` (right), and under it the numbers of heat_ticks(maximum) in white on
    black at the left end, the middle and the right end. (bar_height + LEGEND_TEXT_HEIGHT, width, 4)
    float32 linear RGBA; width must leave room for the numbers (at least 64 pixels)."""
    top = _check_maximum(maximum)
    if isinstance(width, bool) or not isinstance(width, (int, np.integer)) or width < 64:
        raise ValueError(f"width must be a whole number >= 64, got {width!r}")
    if isinstance(bar_height, bool) or not isinstance(bar_height, (int, np.integer)) or bar_height < 1:
        raise ValueError(f"bar_height must be a whole number >= 1, got {bar_height!r}")
    ramp = (np.arange(width) + 0.5) / width * top
    bar = np.repeat(heat_map(ramp, top)[None], bar_height, axis=0)
    text = np.zeros((LEGEND_TEXT_HEIGHT, width, 4), np.float32)
    text[..., 3] = 1.0
    for k, (_, label) in enumerate(heat_ticks(top)):
        mask = _text_mask(label)
        w = min(mask.shape[1], width)
        left = (0, (width - w) // 2, width - w)[k]
        text[2:2 + _GLYPH_H, left:left + w, :3][mask[:, :w]] = 1.0
    return np.concatenate([bar, text])
