"""Draws the 2D teaching diagrams of the tutorial levels into levels/<level>/diagrams/*.png (the
benchmark's charts beside them, bench_*.png, come from tools/bench/charts.py: ./raylab bench --publish,
or redrawn from the published report with /usr/bin/python3 -m tools.bench.published).

Run with Debian's Python (matplotlib from python3-matplotlib):  /usr/bin/python3 tools/make_diagrams.py
[NAME ...] (the functions below; all of them by default).
The geometry is computed, not sketched: the quadtree is built with the same rule as raylab's octree
(split while depth < max_depth and a cell holds more than leaf_size triangles; a triangle goes to every
cell it overlaps by the separating-axis test), and the rays are intersected with real slab and edge tests.
VRT's users asked for diagrams in the tutorial text (thesis, section 5); these are them.

Each diagram is drawn for the sidebar's Tutorial panel (tools/panel_figure.py): a column of squares,
every text large enough to read at the panel's width, few words on the picture (the level's text says
the rest). Orange marks the triangles a ray tests.
"""
import os
import sys

import numpy as np
from matplotlib.patches import Polygon, Rectangle

import panel_figure as page
from panel_figure import SMALL_PT, TEXT_PT

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "addon"))
from raylab import sah_cost  # noqa: E402  (the SAH's one cost model: the diagram prices as the panels do)
LEVELS = os.path.join(ROOT, "levels")
DEPTH_COLORS = ["#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02"]
SHAPE_FILL = "#9ecae1"
SHAPE_EDGE = "#3182bd"
TESTED = "#fd8d3c"          # a triangle the ray tests
ENTERED = "#fdd49e"         # a cell or leaf the ray enters with triangles in it
BOX = "#2ca02c"
RAY = "#d62728"
MISS = "#7f7f7f"
EDGE_PT = 1.2               # triangle outlines: thinner than the boxes they sit in, still a line in the panel
BOX_PT = 3.0


# ---------------------------------------------------------------- geometry


def blob(center=(0.0, 0.0), radius=1.0, n=14, seed=3):
    """A closed, star-shaped 2D outline: a stand-in for a mesh seen from the side."""
    rng = np.random.default_rng(seed)
    angles = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    radii = radius * (0.65 + 0.35 * rng.random(n))
    return np.c_[center[0] + radii * np.cos(angles), center[1] + radii * np.sin(angles)]


def fan_triangles(outline):
    """Triangulates a star-shaped outline as a fan around its centroid."""
    c = outline.mean(axis=0)
    return [np.array([c, outline[i], outline[(i + 1) % len(outline)]]) for i in range(len(outline))]


def rotate(points, degrees, about):
    a = np.radians(degrees)
    r = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    return (points - about) @ r.T + about


def triangle_overlaps_box(tri, lo, hi):
    """Separating-axis test in 2D: box axes and the triangle's edge normals (touching counts)."""
    box = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    axes = [np.array([1.0, 0.0]), np.array([0.0, 1.0])]
    for i in range(3):
        e = tri[(i + 1) % 3] - tri[i]
        axes.append(np.array([-e[1], e[0]]))
    for axis in axes:
        p, q = tri @ axis, box @ axis
        if p.max() < q.min() or q.max() < p.min():
            return False
    return True


def vertex_inside_box(tri, lo, hi):
    """VRT's octree rule: a triangle belongs to a cell only if one of its vertices lies inside."""
    return any(lo[0] <= v[0] <= hi[0] and lo[1] <= v[1] <= hi[1] for v in tri)


def build_quadtree(triangles, lo, hi, max_depth, leaf_size, depth=0):
    """Returns the allocated cells as (lo, hi, depth, is_leaf, triangle ids); empty cells are skipped."""
    ids = [i for i, t in enumerate(triangles) if triangle_overlaps_box(t, lo, hi)]
    if depth == 0:
        ids = list(range(len(triangles)))
    if depth >= max_depth or len(ids) <= leaf_size:
        return [(lo, hi, depth, True, ids)]
    cells = [(lo, hi, depth, False, ids)]
    mid = (lo + hi) / 2.0
    for qx in range(2):
        for qy in range(2):
            clo = np.array([(lo[0], mid[0])[qx], (lo[1], mid[1])[qy]])
            chi = np.array([(mid[0], hi[0])[qx], (mid[1], hi[1])[qy]])
            sub = [triangles[i] for i in ids]
            if any(triangle_overlaps_box(t, clo, chi) for t in sub):
                child = build_quadtree(sub, clo, chi, max_depth, leaf_size, depth + 1)
                # Map the child's local ids back to this cell's triangle ids.
                cells += [(a, b, d, leaf, [ids[k] for k in tid]) for a, b, d, leaf, tid in child]
    return cells


def build_bvh(triangles, ids=None, leaf_size=2, depth=0):
    """A small BVH: split at the median centroid on the longer axis; every triangle in exactly one leaf.
    Returns nodes as (lo, hi, depth, is_leaf, triangle ids)."""
    ids = list(range(len(triangles))) if ids is None else ids
    pts = np.vstack([triangles[i] for i in ids])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    if len(ids) <= leaf_size:
        return [(lo, hi, depth, True, ids)]
    axis = int(np.argmax(hi - lo))
    ids = sorted(ids, key=lambda i: triangles[i].mean(axis=0)[axis])
    half = len(ids) // 2
    return ([(lo, hi, depth, False, ids)] + build_bvh(triangles, ids[:half], leaf_size, depth + 1)
            + build_bvh(triangles, ids[half:], leaf_size, depth + 1))


def square_around(points, margin=0.05):
    lo, hi = points.min(axis=0), points.max(axis=0)
    c, half = (lo + hi) / 2.0, (hi - lo).max() / 2.0 * (1.0 + margin)
    return c - half, c + half


def ray_box(origin, direction, lo, hi):
    """Slab test: (t_entry, t_exit) or None."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / direction
        t0, t1 = (lo - origin) * inv, (hi - origin) * inv
    # fmin / fmax skip the NaN of a ray that runs along a slab's plane (0 times infinity).
    tnear, tfar = np.fmin(t0, t1).max(), np.fmax(t0, t1).min()
    if tfar < max(tnear, 0.0):
        return None
    return max(tnear, 0.0), tfar


def ray_segment(origin, direction, a, b):
    """Distance along the ray to the segment a-b, or None."""
    e = b - a
    m = np.array([[direction[0], -e[0]], [direction[1], -e[1]]])
    if abs(np.linalg.det(m)) < 1e-12:
        return None
    t, s = np.linalg.solve(m, a - origin)
    return t if t > 1e-9 and 0.0 <= s <= 1.0 else None


def ray_triangles(origin, direction, triangles):
    """Closest hit distance of a 2D ray against triangle outlines, or None."""
    hits = [ray_segment(origin, direction, t[i], t[(i + 1) % 3]) for t in triangles for i in range(3)]
    hits = [h for h in hits if h is not None]
    return min(hits) if hits else None


def ray_status(origin, direction, triangles, root_lo, root_hi, leaves):
    """The status raylab's story reports, and the triangle ids tested, for a 2D ray."""
    if ray_box(origin, direction, root_lo, root_hi) is None:
        return "missed_root", set()
    t_hit = ray_triangles(origin, direction, triangles)
    tested = set()
    for lo, hi, ids in leaves:
        span = ray_box(origin, direction, lo, hi)
        if span is not None and ids and (t_hit is None or span[0] <= t_hit):
            tested.update(ids)
    if t_hit is not None:
        return "hit_object", tested
    return ("missed_triangles" if tested else "missed_nodes"), tested


def find_ray(status, origin_x, ys, triangles, root_lo, root_hi, leaves):
    """A ray from (origin_x, y) with the wanted status, taken from the middle of the widest band of
    such rays so that it reads clearly: the diagrams show computed cases, never a sketch."""
    best = None
    for slope in (0.0, 0.15, 0.3, -0.15):
        d = unit([1.0, slope])
        ok = [ray_status(np.array([origin_x, y]), d, triangles, root_lo, root_hi, leaves)[0] == status
              for y in ys]
        start = None
        for i, flag in enumerate(ok + [False]):
            if flag and start is None:
                start = i
            elif not flag and start is not None:
                if best is None or i - start > best[0]:
                    best = (i - start, ys[(start + i - 1) // 2], d)
                start = None
    if best is None:
        raise ValueError(f"no ray with status {status}")
    return np.array([origin_x, best[1]]), best[2]


# ---------------------------------------------------------------- drawing helpers


def draw_triangles(ax, triangles, face=SHAPE_FILL, edge=SHAPE_EDGE, lw=EDGE_PT):
    for t in triangles:
        ax.add_patch(Polygon(t, closed=True, facecolor=face, edgecolor=edge, lw=lw))


def draw_tested(ax, triangles, tested, lw=EDGE_PT):
    """The triangles, the tested ones orange."""
    draw_triangles(ax, [t for i, t in enumerate(triangles) if i not in tested], lw=lw)
    draw_triangles(ax, [triangles[i] for i in sorted(tested)], face=TESTED, edge="#a63603", lw=lw)


def draw_box(ax, lo, hi, color=BOX, lw=BOX_PT, ls="-", fill=None, alpha=1.0, zorder=1):
    ax.add_patch(Rectangle(lo, *(hi - lo), fill=fill is not None, facecolor=fill, edgecolor=color,
                           lw=lw, ls=ls, alpha=alpha, zorder=zorder))


def draw_ray(ax, origin, direction, length, color=RAY, stop=None, lw=3.5):
    """An arrow from origin; `stop` (a distance) ends it at a hit point marked with a dot. A ray that
    hits nothing ends where it leaves the picture (frame() first), never in the next tile."""
    if stop is None:
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        span = ray_box(origin, direction, np.array([x0, y0]), np.array([x1, y1]))
        length = min(length, span[1]) if span is not None else length
    end = origin + direction * (stop if stop is not None else length)
    ax.annotate("", xy=end, xytext=origin, annotation_clip=False, zorder=5,
                arrowprops=dict(arrowstyle="-|>,head_length=0.8,head_width=0.4" if stop is None else "-",
                                color=color, lw=lw, shrinkA=0, shrinkB=0))
    ax.plot(*origin, "o", color=color, ms=10, zorder=6)
    if stop is not None:
        ax.plot(*end, "o", color="black", ms=11, zorder=6)


def mark_entry(ax, origin, direction, lo, hi, color=BOX):
    span = ray_box(origin, direction, lo, hi)
    if span is not None:
        ax.plot(*(origin + direction * span[0]), "o", color=color, ms=12, mec="black", mew=1.5, zorder=7)


def frame(ax, lo, hi, pad=0.3):
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)


def save(fig, level, name):
    folder = os.path.join(LEVELS, level, "diagrams")
    os.makedirs(folder, exist_ok=True)
    return page.save(fig, os.path.join(folder, name))


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


# ---------------------------------------------------------------- the diagrams


def aabb_bounding_box():
    """A shape and its box; the same shape turned by 30 degrees gets a new, bigger box."""
    shape = blob()
    fig = page.figure(2)
    for tile, degrees, title in ((0, 0, "box = min and max\nof the vertices"),
                                 (1, 30, "turned 30°:\na new, bigger box")):
        page.title(fig, tile, title)
        ax = page.axes(fig, tile, bottom=0.1 if degrees else 0.02, height=0.7 if degrees else 0.78)
        s = rotate(shape, degrees, shape.mean(axis=0))
        draw_triangles(ax, fan_triangles(s))
        lo, hi = s.min(axis=0), s.max(axis=0)
        draw_box(ax, lo, hi)
        if degrees == 0:
            ax.plot(*lo, "s", color="black", ms=11)
            ax.plot(*hi, "s", color="black", ms=11)
            ax.annotate("min", lo, xytext=(-12, -8), textcoords="offset points", ha="right", va="top")
            ax.annotate("max", hi, xytext=(12, 8), textcoords="offset points", ha="left", va="bottom")
        else:
            old = rotate(shape, 0, shape.mean(axis=0))
            draw_box(ax, old.min(axis=0), old.max(axis=0), color=MISS, lw=2.0, ls="--")
            page.note(fig, tile, 0.5, 0.09, "dashed: the box before", size=SMALL_PT, ha="center", color="#555555")
        frame(ax, np.array([-1.5, -1.3]), np.array([1.5, 1.3]), pad=0.05)
    return save(fig, "aabb_1", "bounding_box.png")


def aabb_ray_cases():
    """The three fates of a ray against an object's box: ignored, box hit only, object hit."""
    shape = blob(radius=0.9)
    tris = fan_triangles(shape)
    lo, hi = shape.min(axis=0), shape.max(axis=0)
    leaves = [(lo, hi, list(range(len(tris))))]  # the AABB is a root that is also the only leaf
    ys = np.linspace(-1.3, 1.5, 57)
    cases = [("missed_root", "ignored:\nit misses the box"),
             ("missed_triangles", "box hit,\nobject missed"),
             ("hit_object", "object hit")]
    fig = page.figure(len(cases))
    for tile, (status, title) in enumerate(cases):
        o, d = find_ray(status, -2.0, ys, tris, lo, hi, leaves)
        _, tested = ray_status(o, d, tris, lo, hi, leaves)
        page.title(fig, tile, title)
        ax = page.axes(fig, tile, bottom=0.13, height=0.62)
        frame(ax, np.array([-2.1, -1.4]), np.array([1.6, 1.6]), pad=0.05)
        draw_tested(ax, tris, tested)
        draw_box(ax, lo, hi)
        draw_ray(ax, o, d, 3.6, stop=ray_triangles(o, d, tris))
        mark_entry(ax, o, d, lo, hi)
        page.note(fig, tile, 0.5, 0.11, f"{len(tested)} of {len(tris)} triangles tested", ha="center")
    return save(fig, "aabb_2", "ray_vs_box.png")


def sample_scene():
    """A few shapes of different sizes: enough triangles for a readable quadtree."""
    tris = fan_triangles(blob((0.0, 0.0), 1.0, n=16, seed=7))
    tris += fan_triangles(blob((1.6, 1.4), 0.45, n=8, seed=2))
    return tris


def quadtree_depths():
    tris = sample_scene()
    lo, hi = square_around(np.vstack(tris))
    fig = page.figure(2)
    for i, depth in enumerate((1, 2, 3, 4)):
        tile, left = divmod(i, 2)
        fig.text(0.25 + 0.5 * left, page.y(fig, tile, 0.82), f"max depth {depth}", ha="center", va="bottom",
                 fontsize=page.TITLE_PT)
        ax = page.axes(fig, tile, left=0.02 + 0.5 * left, bottom=0.18, width=0.46, height=0.62)
        draw_triangles(ax, tris, lw=0.8)
        for clo, chi, d, leaf, ids in build_quadtree(tris, lo, hi, depth, leaf_size=2):
            if leaf:
                draw_box(ax, clo, chi, color=DEPTH_COLORS[d % len(DEPTH_COLORS)], lw=2.0)
        frame(ax, lo, hi, pad=0.05)
    return save(fig, "octree_1", "quadtree_depth.png")


def vertex_rule_vs_sat():
    """VRT's bug: a large triangle crosses cells that hold none of its vertices. Side by side, as the
    level's text reads them: the vertex rule left, the separating-axis test right."""
    tri = np.array([[0.15, 0.2], [3.85, 0.9], [1.2, 3.8]])
    lo, hi, n = np.array([0.0, 0.0]), np.array([4.0, 4.0]), 4
    fig = page.figure(1)
    page.title(fig, 0, "cells that hold it")
    for left, rule, title in ((0.0, vertex_inside_box, "VRT's rule"), (0.5, triangle_overlaps_box, "raylab's test")):
        fig.text(left + 0.25, page.y(fig, 0, 0.84), title, ha="center", va="top", fontsize=TEXT_PT)
        ax = page.axes(fig, 0, left=left + 0.02, bottom=0.2, width=0.46, height=0.55)
        for i in range(n):
            for j in range(n):
                clo, chi = np.array([i, j], float), np.array([i + 1, j + 1], float)
                overlaps = triangle_overlaps_box(tri, clo, chi)
                kept = rule(tri, clo, chi)
                fill = "#a1d99b" if kept else ("#fc9272" if overlaps else None)
                draw_box(ax, clo, chi, color="#555555", lw=1.2, fill=fill)
        draw_triangles(ax, [tri], face="none", edge=SHAPE_EDGE, lw=3.0)
        ax.plot(tri[:, 0], tri[:, 1], "o", color=SHAPE_EDGE, ms=8)
        frame(ax, lo, hi, pad=0.1)
    page.note(fig, 0, 0.5, 0.16, "red: cells that lose it", ha="center", color="#cb181d")
    return save(fig, "octree_1", "vertex_rule_vs_sat.png")


def separating_axis():
    """The SAT idea: if some axis separates the shadows of triangle and box, they do not overlap. The axis
    is drawn under both shapes, their shadows on it, and the lines that cast them."""
    tri = np.array([[2.2, 0.2], [3.6, 1.0], [2.0, 2.3]])
    lo, hi = np.array([0.3, 0.3]), np.array([1.9, 1.6])
    fig = page.figure(1)
    page.title(fig, 0, "a separating axis")
    ax = page.axes(fig, 0, bottom=0.2, height=0.64)
    draw_box(ax, lo, hi, fill="#c7e9c0")
    draw_triangles(ax, [tri], lw=2.0)
    edge = tri[2] - tri[0]
    axis = unit([edge[1], -edge[0]])  # the normal of the triangle's edge that faces the box
    base = np.array([0.0, -0.75])     # the axis passes below both shapes
    box_pts = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    extent = []
    for pts, color in ((box_pts, BOX), (tri, SHAPE_EDGE)):
        s = (pts - base) @ axis
        for k in (s.argmin(), s.argmax()):  # the lines that cast the shadow, at right angles to the axis
            foot = base + axis * s[k]
            ax.plot(*np.c_[pts[k], foot], color=color, lw=2.0, ls=(0, (2, 2)), zorder=2)
        ax.plot(*np.c_[base + axis * s.min(), base + axis * s.max()], color=color, lw=12, alpha=0.85,
                solid_capstyle="butt", zorder=3)
        extent += [s.min(), s.max()]
    start, end = base + axis * (min(extent) - 0.35), base + axis * (max(extent) + 0.5)
    ax.annotate("", xy=end, xytext=start, annotation_clip=False, zorder=4,
                arrowprops=dict(arrowstyle="-|>,head_length=0.7,head_width=0.35", color="black", lw=2.0,
                                shrinkA=0, shrinkB=0))
    ax.text(*(end + np.array([0.0, 0.18])), "axis", ha="right", va="bottom", fontsize=SMALL_PT)
    frame(ax, np.array([-0.2, -0.95]), np.array([4.3, 2.4]), pad=0.05)
    page.note(fig, 0, 0.5, 0.17, "shadows apart on the axis:\nthe shapes do not touch", ha="center",
              linespacing=1.15)
    return save(fig, "octree_1", "separating_axis.png")


def octree_ray_statuses():
    """The four statuses of one ray through a quadtree, with the cells each ray enters."""
    # Two objects leave the other two quadrants empty: room for a ray that enters no cell.
    tris = fan_triangles(blob((-0.6, -0.6), 0.6, n=10, seed=11)) + fan_triangles(blob((0.9, 0.9), 0.45, 7, 2))
    lo, hi = square_around(np.vstack(tris), margin=0.1)
    leaves = [(c[0], c[1], c[4]) for c in build_quadtree(tris, lo, hi, 3, leaf_size=2) if c[3]]
    ys = np.linspace(lo[1] - 0.6, hi[1] + 0.3, 91)
    cases = [("missed_root", "misses the root: ignored"),
             ("missed_nodes", "enters only empty space"),
             ("missed_triangles", "tests triangles, hits none"),
             ("hit_object", "hits a triangle")]
    fig = page.figure(len(cases))
    for tile, (status, title) in enumerate(cases):
        o, d = find_ray(status, -2.2, ys, tris, lo, hi, leaves)
        _, tested = ray_status(o, d, tris, lo, hi, leaves)
        t_hit = ray_triangles(o, d, tris)
        page.title(fig, tile, status)
        page.note(fig, tile, 0.5, 0.885, title, ha="center")
        ax = page.axes(fig, tile, bottom=0.12, height=0.66)
        frame(ax, np.array([-2.3, ys.min()]), np.array([hi[0], ys.max()]), pad=0.08)
        for clo, chi, ids in leaves:
            span = ray_box(o, d, clo, chi)
            entered = span is not None and ids and (t_hit is None or span[0] <= t_hit)
            draw_box(ax, clo, chi, color="#999999", lw=1.0, fill=ENTERED if entered else None)
        draw_tested(ax, tris, tested, lw=0.8)
        draw_box(ax, lo, hi, lw=2.5)
        draw_ray(ax, o, d, 4.4, stop=t_hit)
        mark_entry(ax, o, d, lo, hi)
        page.note(fig, tile, 0.5, 0.1, f"{len(tested)} of {len(tris)} triangles tested", ha="center")
    return save(fig, "octree_2", "ray_statuses.png")


def bvh_boxes_and_tree():
    """A BVH: boxes around groups of objects (they may overlap), and the tree they form."""
    shapes = {"A": blob((-1.6, 0.4), 0.5, 7, 1), "B": blob((-0.7, -0.5), 0.45, 7, 2),
              "C": blob((1.0, 0.8), 0.5, 7, 3), "D": blob((1.8, -0.3), 0.4, 7, 4)}
    boxes = {k: (v.min(axis=0), v.max(axis=0)) for k, v in shapes.items()}

    def union(*names):
        return (np.min([boxes[n][0] for n in names], axis=0), np.max([boxes[n][1] for n in names], axis=0))

    left, right, root = union("A", "B"), union("C", "D"), union("A", "B", "C", "D")
    fig = page.figure(2)
    page.title(fig, 0, "boxes around groups")
    a = page.axes(fig, 0, height=0.82)
    for name, pts in shapes.items():
        draw_triangles(a, fan_triangles(pts), lw=0.8)
        a.text(*pts.mean(axis=0), name, ha="center", va="center", fontsize=TEXT_PT, weight="bold")
        draw_box(a, *boxes[name], color=DEPTH_COLORS[2], lw=2.0)
    draw_box(a, left[0] - 0.08, left[1] + 0.08, color=DEPTH_COLORS[1], lw=2.5)
    draw_box(a, right[0] - 0.08, right[1] + 0.08, color=DEPTH_COLORS[1], lw=2.5)
    draw_box(a, root[0] - 0.18, root[1] + 0.18, color=DEPTH_COLORS[0], lw=3.0)
    frame(a, root[0], root[1], pad=0.25)
    page.title(fig, 1, "the tree they form")
    b = page.axes(fig, 1, bottom=0.14, height=0.68, picture=False)
    b.axis("off")
    nodes = {"root": (0, 2), "L": (-1.2, 1), "R": (1.2, 1), "A": (-1.8, 0), "B": (-0.6, 0), "C": (0.6, 0),
             "D": (1.8, 0)}
    colors = {"root": DEPTH_COLORS[0], "L": DEPTH_COLORS[1], "R": DEPTH_COLORS[1]}
    for parent, kids in (("root", "LR"), ("L", "AB"), ("R", "CD")):
        for k in kids:
            b.plot(*zip(nodes[parent], nodes[k]), color="#555555", lw=2.0, zorder=1)
    for name, (x, y) in nodes.items():
        wide = 0.5 if name in ("root", "L", "R") else 0.27
        b.add_patch(Rectangle((x - wide, y - 0.27), 2 * wide, 0.54, facecolor="white", lw=3,
                              edgecolor=colors.get(name, DEPTH_COLORS[2]), zorder=2))
        b.text(x, y, "A+B" if name == "L" else "C+D" if name == "R" else name, ha="center", va="center",
               zorder=3)
    b.set_xlim(-2.2, 2.2)
    b.set_ylim(-0.4, 2.4)
    page.note(fig, 1, 0.5, 0.12, "leaves hold the triangles", ha="center")
    return save(fig, "bvh_1", "bvh_tree.png")


def bvh_traversal():
    """Front-to-back traversal with early exit: once a hit is closer than a box, that box is skipped."""
    near, far = blob((-0.5, 0.0), 0.55, 9, 5), blob((1.4, 0.25), 0.55, 9, 6)
    tris_near, tris_far = fan_triangles(near), fan_triangles(far)
    o, d = np.array([-1.7, -0.05]), unit([1, 0.03])
    t_hit = ray_triangles(o, d, tris_near)
    fig = page.figure(1)
    page.title(fig, 0, "closest box first,\nthen stop early")
    ax = page.axes(fig, 0, bottom=0.3, height=0.46)
    frame(ax, np.array([-1.8, -0.7]), np.array([2.1, 1.05]), pad=0.03)
    draw_triangles(ax, tris_near + tris_far, lw=0.8)
    draw_box(ax, near.min(axis=0), near.max(axis=0), color=DEPTH_COLORS[1])
    draw_box(ax, far.min(axis=0), far.max(axis=0), color=MISS, ls="--")
    draw_ray(ax, o, d, 5, stop=t_hit)
    mark_entry(ax, o, d, near.min(axis=0), near.max(axis=0), color=DEPTH_COLORS[1])
    for label, (x, y), color in (("1", (near.min(axis=0)[0], near.max(axis=0)[1]), DEPTH_COLORS[1]),
                                 ("2", (far.min(axis=0)[0], far.max(axis=0)[1]), MISS)):
        ax.text(x, y + 0.06, label, ha="left", va="bottom", fontsize=TEXT_PT, weight="bold", color=color)
    page.note(fig, 0, 0.04, 0.27, "1  nearer box: hit found\n2  starts behind the hit:\n    skipped", linespacing=1.2)
    return save(fig, "bvh_2", "bvh_traversal.png")


def race_work_per_ray():
    """What one ray tests under each structure (the race level's contestants): the tested triangles
    orange, in every panel."""
    tris = sample_scene()
    lo, hi = square_around(np.vstack(tris), margin=0.2)
    o, d = np.array([lo[0] - 0.4, -0.35]), unit([1, 0.12])
    t_hit = ray_triangles(o, d, tris)
    shape_lo, shape_hi = np.vstack(tris).min(axis=0), np.vstack(tris).max(axis=0)
    names = ("none", "aabb", "octree", "bvh")
    fig = page.figure(len(names))
    for tile, name in enumerate(names):
        ax = page.axes(fig, tile, bottom=0.02, height=0.78)
        frame(ax, lo - 0.5, hi, pad=0.05)
        if name == "none":
            tested = set(range(len(tris)))
        elif name == "aabb":
            draw_box(ax, shape_lo, shape_hi)
            tested = set(range(len(tris))) if ray_box(o, d, shape_lo, shape_hi) else set()
        else:
            cells = build_quadtree(tris, lo, hi, 3, 2) if name == "octree" else build_bvh(tris)
            tested = set()
            for clo, chi, dep, is_leaf, ids in cells:
                if not is_leaf:
                    continue
                span = ray_box(o, d, clo, chi)
                entered = span is not None and (t_hit is None or span[0] <= t_hit)
                draw_box(ax, clo, chi, color=DEPTH_COLORS[dep % 6], lw=1.5, fill=ENTERED if entered and ids else None)
                if entered:
                    tested.update(ids)
        draw_tested(ax, tris, tested, lw=0.8)
        draw_ray(ax, o, d, 4, stop=t_hit)
        page.title(fig, tile, f"{name}")
        page.note(fig, tile, 0.5, 0.89, f"{len(tested)} of {len(tris)} triangles tested", ha="center")
    return save(fig, "race", "work_per_ray.png")


def leaking_ray():
    """Two triangles share an edge; a ray through that edge must hit exactly one of them."""
    a, b, c, e = np.array([0, 0.0]), np.array([2, 0.0]), np.array([1, 1.6]), np.array([1, -1.6])
    fig = page.figure(2)
    for tile, title, verdict, color in (
            (0, "Möller–Trumbore", "each triangle rounds the\nedge its own way: both\nsay 'outside', it leaks", RAY),
            (1, "watertight test", "the edge is exact and\nshared: one triangle\nalways takes the ray", BOX)):
        page.title(fig, tile, title)
        ax = page.axes(fig, tile, bottom=0.3, height=0.56)
        draw_triangles(ax, [np.array([a, b, c]), np.array([a, e, b])], lw=2.0)
        ax.plot(*zip(a, b), color="black", lw=3.5)
        ax.plot(1.15, 0.0, "x" if color == RAY else "o", color=color, ms=20, mew=4, zorder=5)
        ax.annotate("the ray,\nhead-on", (1.15, 0.0), xytext=(1.55, 0.75), fontsize=SMALL_PT, ha="left",
                    arrowprops=dict(arrowstyle="-", color="#555555", lw=1.5))
        frame(ax, np.array([-0.1, -1.7]), np.array([2.9, 1.7]), pad=0.05)
        page.note(fig, tile, 0.5, 0.27, verdict, ha="center", color=color, linespacing=1.15)
    return save(fig, "where_methods_fail", "leaking_ray.png")


def shadow_acne():
    """A shadow ray from a surface point: a fixed epsilon fails far from the origin, an ulp offset does not."""
    fig = page.figure(2)
    xs = np.linspace(0, 4, 7)
    for tile, title, robust, verdict in (
            (0, "fixed epsilon 1e-4", False,
             "at scale 10,000 a float\nsteps by 0.001 > 1e-4:\nstarts below the surface\nshadow themselves"),
            (1, "robust offset", True, "the offset grows with\nthe coordinates: every\nstart is on the light side")):
        page.title(fig, tile, title)
        ax = page.axes(fig, tile, bottom=0.36, height=0.5)
        ax.fill_between([-0.2, 4.6], -1, 0, color=SHAPE_FILL)
        ax.plot([-0.2, 4.6], [0, 0], color=SHAPE_EDGE, lw=3)
        for i, x in enumerate(xs):
            # Far from the origin a float cannot hold the exact hit point: it is rounded above or below.
            rounding = 0.0 if robust else (-0.18 if i % 2 else 0.1)
            start = (0.14 if robust else 0.02) + rounding
            self_hit = start < 0
            ax.plot(x, start, "o", color=RAY if self_hit else BOX, ms=10, zorder=5)
            # The shadow ray heads for the light; one that starts below the surface hits it at once.
            end = (x - 0.5 * start, 0.0) if self_hit else (x + 0.45, start + 0.9)
            ax.annotate("", xy=end, xytext=(x, start),
                        arrowprops=dict(arrowstyle="-" if self_hit else "-|>,head_length=0.6,head_width=0.3",
                                        color=RAY if self_hit else BOX, lw=2.5))
            if self_hit:
                ax.plot(*end, "x", color=RAY, ms=14, mew=3.5, zorder=6)
        ax.set_xlim(-0.2, 4.6)
        ax.set_ylim(-0.6, 1.15)
        page.note(fig, tile, 0.5, 0.33, verdict, ha="center", linespacing=1.15)
    return save(fig, "where_methods_fail", "shadow_acne.png")


def bvh_leaves(triangles, leaf_size=2):
    """The BVH's leaves as ray_status takes them: (lo, hi, triangle ids)."""
    return [(lo, hi, ids) for lo, hi, _, is_leaf, ids in build_bvh(triangles, leaf_size=leaf_size) if is_leaf]


def draw_tested_rays(fig, ax, rays, triangles, leaves):
    """Each ray (origin, direction, name) drawn, and under the picture its name with the number of
    triangles it tests (computed), in its colour: wasted tests red."""
    lo = np.vstack(triangles).min(axis=0)
    hi = np.vstack(triangles).max(axis=0)
    for i, (origin, direction, name) in enumerate(rays):
        status, tested = ray_status(origin, direction, triangles, lo, hi, leaves)
        t_hit = ray_triangles(origin, direction, triangles)
        color = RAY if len(tested) > 2 or (tested and status != "hit_object") else BOX
        draw_ray(ax, origin, direction, 6.0, color=color, stop=t_hit)
        outcome = "hit" if status == "hit_object" else "missed"
        page.note(fig, 0, 0.5, 0.2 - 0.085 * i, f"{name}: {len(tested)} tested, {outcome}", ha="center", color=color)


def silhouette_work():
    """Rays through the middle stop at their first hit; rays beside the outline enter leaf after leaf."""
    tris = fan_triangles(blob((0.0, 0.0), 1.0, 16, 7))
    leaves = bvh_leaves(tris)
    fig = page.figure(1)
    page.title(fig, 0, "beside the outline:\nno hit to stop at")
    ax = page.axes(fig, 0, bottom=0.24, height=0.56)
    draw_triangles(ax, tris, lw=0.8)
    for lo, hi, _ in leaves:
        draw_box(ax, lo, hi, color=DEPTH_COLORS[2], lw=1.5)
    outline = np.vstack(tris)
    top = outline[:, 1].max()
    lo, hi = outline.min(axis=0), outline.max(axis=0)

    def beside(ray):  # rays that miss first, then the most triangles tested
        status, tested = ray_status(np.array([-2.2, ray[0]]), unit([1, ray[1]]), tris, lo, hi, leaves)
        return status != "hit_object", len(tested)

    # The ray beside the outline: of the rays that miss, the one that tests the most triangles.
    y, slope = max(((y, k) for y in np.linspace(0.0, top + 0.6, 60) for k in np.linspace(-0.2, 0.0, 21)), key=beside)
    rays = [(np.array([-2.2, 0.05]), unit([1, 0.0]), "middle"), (np.array([-2.2, y]), unit([1, slope]), "beside")]
    frame(ax, np.array([-2.3, -1.1]), np.array([1.6, max(top, y) + 0.2]), pad=0.05)
    draw_tested_rays(fig, ax, rays, tris, leaves)
    return save(fig, "where_work_goes", "silhouette.png")


def grazing_ray():
    """A ray head-on meets the surface in one leaf; a grazing ray runs along it through many."""
    xs = np.linspace(-2.0, 2.0, 11)
    tris = []
    for a, b in zip(xs[:-1], xs[1:]):  # a bumpy strip of ground, two triangles per step
        ya, yb = 0.06 * np.sin(3 * a), 0.06 * np.sin(3 * b)
        tris += [np.array([[a, ya], [b, yb], [a, -0.3]]), np.array([[b, yb], [b, -0.3], [a, -0.3]])]
    leaves = bvh_leaves(tris)
    fig = page.figure(1)
    page.title(fig, 0, "grazing: a ray along the\nsurface, leaf after leaf")
    ax = page.axes(fig, 0, bottom=0.24, height=0.56)
    draw_triangles(ax, tris, lw=0.8)
    for lo, hi, _ in leaves:
        draw_box(ax, lo, hi, color=DEPTH_COLORS[2], lw=1.5)
    ground = np.vstack(tris)
    # The grazing ray: of the nearly flat rays just above the ground, the one that tests the most.
    slope = max(np.linspace(-0.06, 0.0, 120), key=lambda k: len(ray_status(
        np.array([-2.3, 0.1]), unit([1.0, k]), tris, ground.min(axis=0), ground.max(axis=0), leaves)[1]))
    rays = [(np.array([0.3, 1.3]), unit([0.05, -1.0]), "head-on"),
            (np.array([-2.3, 0.1]), unit([1.0, slope]), "grazing")]
    frame(ax, np.array([-2.4, -0.4]), np.array([2.1, 1.4]), pad=0.05)
    draw_tested_rays(fig, ax, rays, tris, leaves)
    return save(fig, "where_work_goes", "grazing.png")


def thin_triangle_box():
    """A long thin diagonal triangle: its box is almost all empty, and every ray through it tests it."""
    thin = [np.array([[-1.8, -1.2], [1.8, 1.2], [1.75, 1.3]])]
    fat = fan_triangles(blob((1.0, -0.55), 0.4, 9, 4))
    tris = thin + fat
    leaves = [(t.min(axis=0), t.max(axis=0), [i]) for i, t in enumerate(tris)]  # a leaf per triangle
    fig = page.figure(1)
    page.title(fig, 0, "a long thin triangle:\na big, empty box")
    ax = page.axes(fig, 0, bottom=0.24, height=0.56)
    draw_triangles(ax, fat, lw=0.8)
    draw_triangles(ax, thin, face=ENTERED, edge="#e6550d", lw=2.0)
    draw_box(ax, thin[0].min(axis=0), thin[0].max(axis=0), color="#e6550d", lw=2.5, ls="--")
    along = unit(thin[0][1] - thin[0][0])
    rays = [(np.array([-2.4, -0.85]), along, "beside it"),   # beside the triangle, all through its box
            (np.array([2.6, -0.5]), unit([-1, 0.0]), "elsewhere")]
    frame(ax, np.array([-2.5, -1.3]), np.array([2.7, 1.45]), pad=0.05)
    draw_tested_rays(fig, ax, rays, tris, leaves)
    return save(fig, "where_work_goes", "thin_triangles.png")


def sah_split_cost(triangles, left, right):
    """The SAH cost of splitting into `left` and `right` (triangle ids) in 2D, in triangle tests as raylab
    counts it (sah_cost.split_tests), where a box's chance of being entered is its perimeter over the parent's."""
    def box(ids):
        pts = np.vstack([triangles[i] for i in ids])
        return pts.min(axis=0), pts.max(axis=0)

    def perimeter(lo, hi):
        return 2.0 * float(np.sum(hi - lo))
    parent = perimeter(*box(left + right))
    return sah_cost.split_tests([(perimeter(*box(side)) / parent, len(side)) for side in (left, right)])


def sah_against_median():
    """One split of a scene with a crowd on one side and a lone triangle far off: the object median puts
    the crowd in both halves and stretches a box over the empty middle; the SAH cuts off the empty space."""
    crowd = fan_triangles(blob((-1.3, -0.2), 0.75, 31, 5))  # enough triangles that a split pays
    far = [np.array([[1.75, 0.75], [2.15, 0.85], [1.95, 1.2]])]
    tris = crowd + far
    order = sorted(range(len(tris)), key=lambda i: tris[i].mean(axis=0)[0])
    half = len(order) // 2
    splits = {"object median": (order[:half], order[half:])}
    costs = {k: sah_split_cost(tris, *v) for k, v in splits.items()}
    best = min(((order[:k], order[k:]) for k in range(1, len(order))), key=lambda lr: sah_split_cost(tris, *lr))
    splits["SAH"] = best
    costs["SAH"] = sah_split_cost(tris, *best)
    leaf_cost = sah_cost.leaf_tests(len(tris))
    fig = page.figure(2)
    lo, hi = square_around(np.vstack(tris), margin=0.08)
    for tile, name in enumerate(("object median", "SAH")):
        left, right = splits[name]
        page.title(fig, tile, f"{name} split: {costs[name]:.1f}\ntriangle tests (leaf {leaf_cost})")
        ax = page.axes(fig, tile, bottom=0.06, height=0.74)
        draw_triangles(ax, [tris[i] for i in left], face=SHAPE_FILL, lw=0.8)
        draw_triangles(ax, [tris[i] for i in right], face=ENTERED, edge="#a63603", lw=0.8)
        for ids, colour in ((left, DEPTH_COLORS[0]), (right, DEPTH_COLORS[1])):
            pts = np.vstack([tris[i] for i in ids])
            draw_box(ax, pts.min(axis=0) - 0.04, pts.max(axis=0) + 0.04, color=colour, lw=2.5)
        frame(ax, lo, hi, pad=0.05)
    return save(fig, "why_sah", "sah_against_median.png")


DIAGRAMS = [aabb_bounding_box, aabb_ray_cases, quadtree_depths, vertex_rule_vs_sat, separating_axis,
            octree_ray_statuses, bvh_boxes_and_tree, bvh_traversal, race_work_per_ray, leaking_ray,
            shadow_acne, silhouette_work, grazing_ray, thin_triangle_box, sah_against_median]

if __name__ == "__main__":
    wanted = sys.argv[1:]
    for draw in DIAGRAMS:
        if not wanted or draw.__name__ in wanted:
            print(draw())
