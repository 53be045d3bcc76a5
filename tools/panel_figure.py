"""Figures for the Tutorial panel: the page every level diagram (tools/make_diagrams.py) and benchmark
chart (tools/bench/charts.py) is drawn on.

Blender shows a picture in a panel only in a square (addon/raylab/blender/diagrams.py), so a figure is a
column of `tiles` squares, each a picture of its own: no text crosses from one square into the next,
where the panel leaves a gap. At Blender's default sidebar width (220 px at UI scale 1) a square is
PANEL_TILE_PX wide; it is drawn TILE_PX wide, so a text of SMALL_PT is MIN_TEXT_PX tall there (its
font's em), and lines of LINE_PT or more stay a pixel wide.

save() writes, into the PNG itself, every text as it was drawn (its size and box): a tEXt chunk
"raylab:texts" that tests/python/test_diagrams.py reads, so a picture and its measurements cannot part.
"""
import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.text import Text  # noqa: E402

TILE_INCHES = 4.0
DPI = 100
TILE_PX = int(TILE_INCHES * DPI)
PANEL_TILE_PX = 160   # a square's width in the Tutorial panel at Blender's default sidebar, UI scale 1
MIN_TEXT_PX = 9.0     # the smallest font (em) a text may have there
SMALL_PT = 17         # the smallest text: 17 pt at 100 dpi is 23.6 px, 9.4 px in the panel
TEXT_PT = 18
TITLE_PT = 20
LINE_PT = 2.0         # 2.8 px drawn, 1.1 px in the panel
METADATA_KEY = "raylab:texts"

STYLE = {"font.size": TEXT_PT, "axes.titlesize": TITLE_PT, "axes.labelsize": SMALL_PT,
         "xtick.labelsize": SMALL_PT, "ytick.labelsize": SMALL_PT, "legend.fontsize": SMALL_PT,
         "legend.title_fontsize": SMALL_PT, "lines.linewidth": 3.0, "lines.markersize": 9,
         "axes.linewidth": 1.5, "xtick.major.width": 1.5, "ytick.major.width": 1.5, "xtick.major.size": 6,
         "ytick.major.size": 6, "xtick.minor.size": 3, "ytick.minor.size": 3, "grid.linewidth": 1.2,
         "axes.formatter.use_mathtext": False, "figure.facecolor": "white", "savefig.facecolor": "white"}
plt.rcParams.update(STYLE)


def figure(tiles=1):
    """A figure of `tiles` squares one under the other (index 0 is the top one)."""
    fig = plt.figure(figsize=(TILE_INCHES, TILE_INCHES * tiles), dpi=DPI)
    fig.raylab_tiles = tiles
    return fig


def rect(fig, tile, left=0.0, bottom=0.0, width=1.0, height=1.0):
    """A rectangle given in the fractions of one tile, in the figure's fractions."""
    n = fig.raylab_tiles
    return left, (n - 1 - tile + bottom) / n, width, height / n


def y(fig, tile, fraction):
    """A height in one tile (0 its bottom, 1 its top) in the figure's fractions."""
    n = fig.raylab_tiles
    return (n - 1 - tile + fraction) / n


def axes(fig, tile, left=0.02, bottom=0.02, width=0.96, height=0.8, picture=True):
    """Axes inside a tile. A picture has equal scales and no axis: it shows exactly the limits it is given,
    as large as fits the room, centred in it."""
    ax = fig.add_axes(rect(fig, tile, left, bottom, width, height))
    if picture:
        ax.set_aspect("equal", adjustable="box")
        ax.axis("off")
    return ax


def title(fig, tile, text, top=0.975, size=TITLE_PT, **options):
    """A tile's title, centred at its top."""
    return fig.text(0.5, y(fig, tile, top), text, ha="center", va="top", fontsize=size, **options)


def note(fig, tile, x, top, text, size=TEXT_PT, **options):
    """A text in a tile, placed by its top edge (x, top in the tile's fractions)."""
    options.setdefault("va", "top")
    return fig.text(x, y(fig, tile, top), text, fontsize=size, **options)


def drawn_texts(fig):
    """Every text the figure draws: its string, size in pixels (the font's em), box (x0, y0, x1, y1) in
    pixels from the top-left, and whether it is mathtext (whose sub- and superscripts are smaller).
    Recorded while the figure draws, so a tick label out of view or a text switched off is not there."""
    drawn = []
    original = Text.draw

    def record(self, renderer):
        original(self, renderer)
        if self.get_visible() and self.get_text().strip():
            drawn.append(self)

    Text.draw = record
    try:
        fig.canvas.draw()
    finally:
        Text.draw = original
    renderer, height = fig.canvas.get_renderer(), fig.bbox.height
    texts = []
    for text in drawn:
        box = text.get_window_extent(renderer)
        texts.append({"text": text.get_text(), "px": round(text.get_fontsize() * DPI / 72.0, 2),
                      "box": [round(box.x0, 1), round(height - box.y1, 1), round(box.x1, 1), round(height - box.y0, 1)],
                      "mathtext": text.get_text().count("$") >= 2})
    return texts


def save(fig, path):
    """Saves the figure at its exact size (TILE_PX wide), with its texts' measurements in the PNG."""
    texts = drawn_texts(fig)
    record = {"tiles": fig.raylab_tiles, "tile_px": TILE_PX, "texts": texts}
    fig.savefig(path, dpi=DPI, metadata={METADATA_KEY: json.dumps(record)})
    plt.close(fig)
    return path
