"""Draws the 2D teaching diagrams of the tutorial levels into levels/<level>/diagrams/*.png.

Run with Debian's Python (matplotlib from python3-matplotlib):  /usr/bin/python3 tools/make_diagrams.py
The geometry is computed, not sketched: the quadtree is built with the same rule as raylab's octree
(split while depth < max_depth and a cell holds more than leaf_size triangles; a triangle goes to every
cell it overlaps by the separating-axis test), and the rays are intersected with real slab and edge tests.
VRT's users asked for diagrams in the tutorial text (thesis, section 5); these are them.
"""
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Polygon, Rectangle  # noqa: E402

LEVELS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "levels")
DEPTH_COLORS = ["#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02"]
SHAPE_FILL = "#9ecae1"
SHAPE_EDGE = "#3182bd"
BOX = "#2ca02c"
RAY = "#d62728"
MISS = "#7f7f7f"
plt.rcParams.update({"font.size": 12, "axes.titlesize": 13})


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
    with np.errstate(divide="ignore"):
        inv = 1.0 / direction
    t0, t1 = (lo - origin) * inv, (hi - origin) * inv
    tnear, tfar = np.minimum(t0, t1).max(), np.maximum(t0, t1).min()
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


def new_figure(ncols=1, nrows=1, width=4.8, height=3.8):
    fig, axes = plt.subplots(nrows, ncols, figsize=(width * ncols, height * nrows), squeeze=False)
    for ax in axes.flat:
        ax.set_aspect("equal")
        ax.axis("off")
    return fig, axes.flat


def draw_triangles(ax, triangles, face=SHAPE_FILL, edge=SHAPE_EDGE, lw=0.8):
    for t in triangles:
        ax.add_patch(Polygon(t, closed=True, facecolor=face, edgecolor=edge, lw=lw))


def draw_box(ax, lo, hi, color=BOX, lw=2.0, ls="-", fill=None, alpha=1.0):
    ax.add_patch(Rectangle(lo, *(hi - lo), fill=fill is not None, facecolor=fill, edgecolor=color,
                           lw=lw, ls=ls, alpha=alpha))


def draw_ray(ax, origin, direction, length, color=RAY, stop=None):
    """An arrow from origin; `stop` (a distance) ends it at a hit point marked with a dot."""
    end = origin + direction * (stop if stop is not None else length)
    ax.annotate("", xy=end, xytext=origin, annotation_clip=False,
                arrowprops=dict(arrowstyle="-|>" if stop is None else "-", color=color, lw=2.2))
    ax.plot(*origin, "o", color=color, ms=6)
    if stop is not None:
        ax.plot(*end, "o", color="black", ms=7, zorder=5)


def mark_entry(ax, origin, direction, lo, hi, color=BOX):
    span = ray_box(origin, direction, lo, hi)
    if span is not None:
        ax.plot(*(origin + direction * span[0]), "o", color=color, ms=8, mec="black", zorder=6)


def frame(ax, lo, hi, pad=0.3):
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)


def save(fig, level, name):
    folder = os.path.join(LEVELS, level, "diagrams")
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, name)
    fig.tight_layout()
    fig.savefig(path, dpi=100, facecolor="white", bbox_inches="tight", pad_inches=0.15)
    plt.close(fig)
    return path


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


# ---------------------------------------------------------------- the diagrams


def aabb_bounding_box():
    """A shape and its box; the same shape turned by 30 degrees gets a new, bigger box."""
    shape = blob()
    fig, (a, b) = new_figure(2)
    for ax, degrees, title in ((a, 0, "box = min and max\nof all vertices"),
                               (b, 30, "object turned 30°:\nbox computed again")):
        s = rotate(shape, degrees, shape.mean(axis=0))
        draw_triangles(ax, fan_triangles(s))
        lo, hi = s.min(axis=0), s.max(axis=0)
        draw_box(ax, lo, hi)
        if degrees == 0:
            ax.plot(*lo, "s", color="black", ms=7)
            ax.plot(*hi, "s", color="black", ms=7)
            ax.annotate("min", lo, xytext=(-28, -14), textcoords="offset points")
            ax.annotate("max", hi, xytext=(6, 4), textcoords="offset points")
        else:
            old = rotate(shape, 0, shape.mean(axis=0))
            draw_box(ax, old.min(axis=0), old.max(axis=0), color=MISS, lw=1.2, ls="--")
        ax.set_title(title)
        frame(ax, np.array([-1.3, -1.3]), np.array([1.3, 1.3]))
    return save(fig, "aabb_1", "bounding_box.png")


def aabb_ray_cases():
    """The three fates of a ray against an object's box: ignored, box hit only, object hit."""
    shape = blob(radius=0.9)
    tris = fan_triangles(shape)
    lo, hi = shape.min(axis=0), shape.max(axis=0)
    leaves = [(lo, hi, list(range(len(tris))))]  # the AABB is a root that is also the only leaf
    ys = np.linspace(-1.3, 1.5, 57)
    cases = [("missed_root", "ignored:\nmisses the box,\nno triangle tested"),
             ("missed_triangles", "box hit, object missed:\nall triangles tested"),
             ("hit_object", "object hit:\nall triangles tested")]
    fig, axes = new_figure(2, 2, width=3.8, height=3.8)  # near square: the sidebar shows it in a square
    axes = list(axes)
    axes[3].text(0.0, 0.5, "a box test costs about\none triangle test:\na ray that misses the box\n"
                 "saves all the triangle tests", fontsize=12, va="center")
    for ax, (status, title) in zip(axes, cases):
        o, d = find_ray(status, -2.0, ys, tris, lo, hi, leaves)
        draw_triangles(ax, tris)
        draw_box(ax, lo, hi)
        draw_ray(ax, o, d, 3.6, stop=ray_triangles(o, d, tris))
        mark_entry(ax, o, d, lo, hi)
        ax.set_title(title, fontsize=11)
        frame(ax, np.array([-2.1, -1.4]), np.array([1.6, 1.6]), pad=0.1)
    return save(fig, "aabb_2", "ray_vs_box.png")


def sample_scene():
    """A few shapes of different sizes: enough triangles for a readable quadtree."""
    tris = fan_triangles(blob((0.0, 0.0), 1.0, n=16, seed=7))
    tris += fan_triangles(blob((1.6, 1.4), 0.45, n=8, seed=2))
    return tris


def quadtree_depths():
    tris = sample_scene()
    lo, hi = square_around(np.vstack(tris))
    fig, axes = new_figure(2, 2, width=3.6, height=3.8)
    for ax, depth in zip(axes, (1, 2, 3, 4)):
        draw_triangles(ax, tris, lw=0.5)
        for clo, chi, d, leaf, ids in build_quadtree(tris, lo, hi, depth, leaf_size=2):
            if leaf:
                draw_box(ax, clo, chi, color=DEPTH_COLORS[d % len(DEPTH_COLORS)], lw=1.6)
        ax.set_title(f"max depth {depth}")
        frame(ax, lo, hi, pad=0.1)
    fig.suptitle("leaves coloured by depth; empty cells are not stored", fontsize=12)
    return save(fig, "octree_1", "quadtree_depth.png")


def vertex_rule_vs_sat():
    """VRT's bug: a large triangle crosses cells that hold none of its vertices."""
    tri = np.array([[0.15, 0.2], [3.85, 0.9], [1.2, 3.8]])
    lo, hi, n = np.array([0.0, 0.0]), np.array([4.0, 4.0]), 4
    fig, (a, b) = new_figure(2)
    for ax, rule, title in ((a, vertex_inside_box, "VRT: a vertex inside the cell\n(red: cells that lose it)"),
                            (b, triangle_overlaps_box, "raylab: separating-axis test\n(every cell it touches)")):
        for i in range(n):
            for j in range(n):
                clo, chi = np.array([i, j], float), np.array([i + 1, j + 1], float)
                overlaps = triangle_overlaps_box(tri, clo, chi)
                kept = rule(tri, clo, chi)
                fill = "#a1d99b" if kept else ("#fc9272" if overlaps else None)
                draw_box(ax, clo, chi, color="#555555", lw=1.0, fill=fill)
        draw_triangles(ax, [tri], face="none", edge=SHAPE_EDGE, lw=2.5)
        ax.plot(tri[:, 0], tri[:, 1], "o", color=SHAPE_EDGE, ms=7)
        ax.set_title(title, fontsize=11)
        frame(ax, lo, hi, pad=0.1)
    return save(fig, "octree_1", "vertex_rule_vs_sat.png")


def separating_axis():
    """The SAT idea: if some axis separates the shadows of triangle and box, they do not overlap."""
    tri = np.array([[2.2, 0.2], [3.6, 1.0], [2.0, 2.3]])
    lo, hi = np.array([0.3, 0.3]), np.array([1.9, 1.6])
    fig, (ax,) = new_figure(1, width=5.2, height=4.2)
    draw_box(ax, lo, hi, fill="#c7e9c0")
    draw_triangles(ax, [tri])
    edge = tri[2] - tri[0]
    axis = unit([edge[1], -edge[0]])  # the normal of the triangle's edge facing the box
    base = np.array([0.6, -0.6])
    ax.annotate("", xy=base + axis * 4.2, xytext=base - axis * 0.6,
                arrowprops=dict(arrowstyle="-|>", color="black", lw=1.2))
    box_pts = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    for pts, color in ((box_pts, BOX), (tri, SHAPE_EDGE)):
        s = (pts - base) @ axis
        ax.plot(*np.c_[base + axis * s.min(), base + axis * s.max()], color=color, lw=6, alpha=0.8)
    ax.text(2.4, -0.55, "their shadows on this axis\ndo not overlap: no overlap", fontsize=11)
    ax.set_title("separating-axis test (touching counts as overlap)", fontsize=12)
    frame(ax, np.array([-0.2, -1.0]), np.array([4.6, 2.6]), pad=0.1)
    return save(fig, "octree_1", "separating_axis.png")


def octree_ray_statuses():
    """The four statuses of one ray through a quadtree, with the cells each ray enters."""
    # Two objects leave the other two quadrants empty: room for a ray that enters no cell.
    tris = fan_triangles(blob((-0.6, -0.6), 0.6, n=10, seed=11)) + fan_triangles(blob((0.9, 0.9), 0.45, 7, 2))
    lo, hi = square_around(np.vstack(tris), margin=0.1)
    leaves = [(c[0], c[1], c[4]) for c in build_quadtree(tris, lo, hi, 3, leaf_size=2) if c[3]]
    ys = np.linspace(lo[1] - 0.6, hi[1] + 0.3, 91)
    cases = [("missed_root", "misses the root: ignored"),
             ("missed_nodes", "enters the root,\nbut no cell with triangles"),
             ("missed_triangles", "enters cells with triangles,\ntests them, hits none"),
             ("hit_object", "hits a triangle")]
    fig, axes = new_figure(2, 2, width=4.2, height=4.2)
    for ax, (status, title) in zip(axes, cases):
        o, d = find_ray(status, -2.2, ys, tris, lo, hi, leaves)
        _, tested = ray_status(o, d, tris, lo, hi, leaves)
        t_hit = ray_triangles(o, d, tris)
        draw_triangles(ax, tris, lw=0.5)
        draw_box(ax, lo, hi, lw=1.4)
        for clo, chi, ids in leaves:
            span = ray_box(o, d, clo, chi)
            entered = span is not None and ids and (t_hit is None or span[0] <= t_hit)
            draw_box(ax, clo, chi, color="#999999", lw=0.6, fill="#fdd49e" if entered else None)
        draw_triangles(ax, [tris[i] for i in tested], face="#fd8d3c", lw=0.5)
        draw_ray(ax, o, d, 4.4, stop=t_hit)
        mark_entry(ax, o, d, lo, hi)
        ax.set_title(f"{status}\n{title}", fontsize=11)
        ax.text(hi[0] + 0.05, lo[1], f"triangles\ntested:\n{len(tested)} of {len(tris)}", fontsize=10)
        frame(ax, np.array([-2.3, lo[1] - 0.1]), hi + np.array([0.9, 0.0]), pad=0.08)
    return save(fig, "octree_2", "ray_statuses.png")


def bvh_boxes_and_tree():
    """A BVH: boxes around groups of objects (they may overlap), and the tree they form."""
    shapes = {"A": blob((-1.6, 0.4), 0.5, 7, 1), "B": blob((-0.7, -0.5), 0.45, 7, 2),
              "C": blob((1.0, 0.8), 0.5, 7, 3), "D": blob((1.8, -0.3), 0.4, 7, 4)}
    boxes = {k: (v.min(axis=0), v.max(axis=0)) for k, v in shapes.items()}

    def union(*names):
        return (np.min([boxes[n][0] for n in names], axis=0), np.max([boxes[n][1] for n in names], axis=0))

    left, right, root = union("A", "B"), union("C", "D"), union("A", "B", "C", "D")
    fig, (a, b) = new_figure(2, width=4.8, height=3.8)
    for name, pts in shapes.items():
        draw_triangles(a, fan_triangles(pts), lw=0.4)
        a.text(*pts.mean(axis=0), name, ha="center", va="center", fontsize=12, weight="bold")
        draw_box(a, *boxes[name], color=DEPTH_COLORS[2], lw=1.2)
    draw_box(a, left[0] - 0.08, left[1] + 0.08, color=DEPTH_COLORS[1], lw=1.8)
    draw_box(a, right[0] - 0.08, right[1] + 0.08, color=DEPTH_COLORS[1], lw=1.8)
    draw_box(a, root[0] - 0.18, root[1] + 0.18, color=DEPTH_COLORS[0], lw=2.2)
    a.set_title("boxes around groups")
    frame(a, root[0], root[1], pad=0.3)
    nodes = {"root": (0, 2), "L": (-1.2, 1), "R": (1.2, 1), "A": (-1.8, 0), "B": (-0.6, 0), "C": (0.6, 0),
             "D": (1.8, 0)}
    colors = {"root": DEPTH_COLORS[0], "L": DEPTH_COLORS[1], "R": DEPTH_COLORS[1]}
    for parent, kids in (("root", "LR"), ("L", "AB"), ("R", "CD")):
        for k in kids:
            b.plot(*zip(nodes[parent], nodes[k]), color="#555555", lw=1.2, zorder=1)
    for name, (x, y) in nodes.items():
        b.add_patch(Rectangle((x - 0.35, y - 0.25), 0.7, 0.5, facecolor="white", lw=2,
                              edgecolor=colors.get(name, DEPTH_COLORS[2]), zorder=2))
        b.text(x, y, "A+B" if name == "L" else "C+D" if name == "R" else name, ha="center", va="center",
               zorder=3)
    b.text(0, -0.7, "leaves hold triangles", ha="center", fontsize=11)
    b.set_title("the tree: every object in one leaf")
    b.set_xlim(-2.4, 2.4)
    b.set_ylim(-1.0, 2.5)
    return save(fig, "bvh_1", "bvh_tree.png")


def bvh_traversal():
    """Front-to-back traversal with early exit: once a hit is closer than a box, that box is skipped."""
    near, far = blob((-0.5, 0.0), 0.55, 9, 5), blob((1.4, 0.25), 0.55, 9, 6)
    tris_near, tris_far = fan_triangles(near), fan_triangles(far)
    o, d = np.array([-2.2, -0.05]), unit([1, 0.03])
    t_hit = ray_triangles(o, d, tris_near)
    fig, (ax,) = new_figure(1, width=6.4, height=3.6)
    draw_triangles(ax, tris_near + tris_far, lw=0.5)
    draw_box(ax, near.min(axis=0), near.max(axis=0), color=DEPTH_COLORS[1])
    draw_box(ax, far.min(axis=0), far.max(axis=0), color=MISS, ls="--")
    draw_ray(ax, o, d, 5, stop=t_hit)
    mark_entry(ax, o, d, near.min(axis=0), near.max(axis=0), color=DEPTH_COLORS[1])
    ax.text(-0.9, -0.9, "1. nearer box first:\n    hit found here", fontsize=11)
    ax.text(0.9, -0.9, "2. this box starts behind\n    the hit: skipped", fontsize=11)
    ax.set_title("closest box first, then stop early")
    frame(ax, np.array([-2.3, -1.1]), np.array([2.1, 1.0]), pad=0.1)
    return save(fig, "bvh_2", "bvh_traversal.png")


def race_work_per_ray():
    """What one ray tests under each structure (the race level's four contestants)."""
    tris = sample_scene()
    lo, hi = square_around(np.vstack(tris), margin=0.2)
    o, d = np.array([lo[0] - 0.4, -0.35]), unit([1, 0.12])
    fig, axes = new_figure(2, 2, width=3.4, height=3.5)
    t_hit = ray_triangles(o, d, tris)
    shape_lo, shape_hi = np.vstack(tris).min(axis=0), np.vstack(tris).max(axis=0)
    for ax, name in zip(axes, ("none", "aabb", "octree", "bvh")):
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
                hit = span is not None and (t_hit is None or span[0] <= t_hit)
                draw_box(ax, clo, chi, color=DEPTH_COLORS[dep % 6], lw=0.7,
                         fill="#fdd49e" if hit and ids else None)
                if hit:
                    tested.update(ids)
        draw_triangles(ax, [tris[i] for i in range(len(tris))], lw=0.4,
                       face=SHAPE_FILL if name != "none" else "#fdd49e")
        draw_ray(ax, o, d, 4, stop=t_hit)
        ax.set_title(f"{name}\n{len(tested)} of {len(tris)} triangles tested", fontsize=11)
        frame(ax, lo - 0.4, hi, pad=0.05)
    return save(fig, "race", "work_per_ray.png")


def leaking_ray():
    """Two triangles share an edge; a ray through that edge must hit exactly one of them."""
    a, b, c, e = np.array([0, 0.0]), np.array([2, 0.0]), np.array([1, 1.6]), np.array([1, -1.6])
    fig, (l, r) = new_figure(2, width=4.2, height=4.2)
    for ax, title, verdict, color in (
            (l, "Möller–Trumbore", "each triangle computes the edge\nwith its own rounding: both say\n"
             "'outside' -> the ray leaks", RAY),
            (r, "watertight (Woop et al.)", "edge functions are shared\nand exact at ties: one\n"
             "triangle always takes it", BOX)):
        draw_triangles(ax, [np.array([a, b, c]), np.array([a, e, b])], lw=1.5)
        ax.plot(*zip(a, b), color="black", lw=2.5)
        ax.plot(1.15, 0.0, "x" if color == RAY else "o", color=color, ms=14, mew=3)
        ax.text(1.3, 0.1, "ray hits the\nshared edge\n(seen head-on)", fontsize=10)
        ax.text(-0.1, -2.55, verdict, fontsize=10.5, color=color)
        ax.set_title(title)
        frame(ax, np.array([-0.1, -2.6]), np.array([2.1, 1.7]), pad=0.1)
    return save(fig, "where_methods_fail", "leaking_ray.png")


def shadow_acne():
    """A shadow ray from a surface point: a fixed epsilon fails far from the origin, an ulp offset does not."""
    fig, (l, r) = new_figure(2, width=4.4, height=3.8)
    xs = np.linspace(0, 4, 9)
    for ax, title, robust in ((l, "fixed epsilon = 1e-4", False), (r, "robust offset (in ulps)", True)):
        ax.fill_between([0, 4], -1, 0, color=SHAPE_FILL)
        ax.plot([0, 4], [0, 0], color=SHAPE_EDGE, lw=2)
        for i, x in enumerate(xs):
            # Far from the origin a float cannot hold the exact hit point: it is rounded above or below.
            rounding = 0.0 if robust else (-0.18 if i % 2 else 0.1)
            start = (0.14 if robust else 0.02) + rounding
            self_hit = start < 0
            ax.plot(x, start, "o", color=RAY if self_hit else BOX, ms=6)
            # The shadow ray heads for the light; one that starts below the surface hits it at once.
            end = (x - 0.5 * start, 0.0) if self_hit else (x + 0.45, start + 0.9)
            ax.annotate("", xy=end, xytext=(x, start),
                        arrowprops=dict(arrowstyle="-" if self_hit else "-|>", color=RAY if self_hit else BOX,
                                        lw=1.6))
            if self_hit:
                ax.plot(*end, "x", color=RAY, ms=9, mew=2.5)
        ax.set_title(title)
        ax.text(0.0, -0.8, "start points below the surface\nshadow themselves: dark speckles"
                if not robust else "offset grows with the coordinates:\nalways on the light side",
                fontsize=10.5)
        ax.set_xlim(-0.2, 4.6)
        ax.set_ylim(-1.0, 1.2)
    fig.suptitle("at scene scale 10,000 a float's step is ~0.001: larger than 1e-4", fontsize=11)
    return save(fig, "where_methods_fail", "shadow_acne.png")


def bvh_leaves(triangles, leaf_size=2):
    """The BVH's leaves as ray_status takes them: (lo, hi, triangle ids)."""
    return [(lo, hi, ids) for lo, hi, _, is_leaf, ids in build_bvh(triangles, leaf_size=leaf_size) if is_leaf]


def draw_tested_rays(ax, rays, triangles, leaves):
    """Each ray (origin, direction, label position) with the number of triangles it tests (computed)."""
    lo = np.vstack(triangles).min(axis=0)
    hi = np.vstack(triangles).max(axis=0)
    for origin, direction, where in rays:
        status, tested = ray_status(origin, direction, triangles, lo, hi, leaves)
        t_hit = ray_triangles(origin, direction, triangles)
        color = RAY if len(tested) > 2 or (tested and status != "hit_object") else BOX  # wasted tests in red
        draw_ray(ax, origin, direction, 6.0, color=color, stop=t_hit)
        ax.text(*where, f"{len(tested)} tested" + (", hit" if status == "hit_object" else ", missed"),
                fontsize=10.5, color=color)


def silhouette_work():
    """Rays through the middle stop at their first hit; rays beside the outline enter leaf after leaf."""
    tris = fan_triangles(blob((0.0, 0.0), 1.0, 16, 7))
    leaves = bvh_leaves(tris)
    fig, (ax,) = new_figure(1, width=6.4, height=4.0)
    draw_triangles(ax, tris, lw=0.5)
    for lo, hi, _ in leaves:
        draw_box(ax, lo, hi, color=DEPTH_COLORS[2], lw=0.8)
    outline = np.vstack(tris)
    top = outline[:, 1].max()
    lo, hi = outline.min(axis=0), outline.max(axis=0)

    def beside(ray):  # rays that miss first, then the most triangles tested
        status, tested = ray_status(np.array([-2.6, ray[0]]), unit([1, ray[1]]), tris, lo, hi, leaves)
        return status != "hit_object", len(tested)

    # The ray beside the outline: of the rays that miss, the one that tests the most triangles.
    y, slope = max(((y, k) for y in np.linspace(0.0, top + 0.6, 60) for k in np.linspace(-0.2, 0.0, 21)), key=beside)
    rays = [(np.array([-2.6, 0.05]), unit([1, 0.0]), (-2.6, 0.15)),
            (np.array([-2.6, y]), unit([1, slope]), (-2.6, y + 0.12))]
    draw_tested_rays(ax, rays, tris, leaves)
    ax.set_title("the silhouette: a ray just beside the object hits nothing that stops it")
    frame(ax, np.array([-2.7, -1.1]), np.array([2.7, max(top, y) + 0.35]), pad=0.05)
    return save(fig, "where_work_goes", "silhouette.png")


def grazing_ray():
    """A ray head-on meets the surface in one leaf; a grazing ray runs along it through many."""
    xs = np.linspace(-2.0, 2.0, 11)
    tris = []
    for a, b in zip(xs[:-1], xs[1:]):  # a bumpy strip of ground, two triangles per step
        ya, yb = 0.06 * np.sin(3 * a), 0.06 * np.sin(3 * b)
        tris += [np.array([[a, ya], [b, yb], [a, -0.3]]), np.array([[b, yb], [b, -0.3], [a, -0.3]])]
    leaves = bvh_leaves(tris)
    fig, (ax,) = new_figure(1, width=6.4, height=3.4)
    draw_triangles(ax, tris, lw=0.5)
    for lo, hi, _ in leaves:
        draw_box(ax, lo, hi, color=DEPTH_COLORS[2], lw=0.8)
    ground = np.vstack(tris)
    # The grazing ray: of the nearly flat rays just above the ground, the one that tests the most.
    slope = max(np.linspace(-0.06, 0.0, 120), key=lambda k: len(ray_status(
        np.array([-2.3, 0.1]), unit([1.0, k]), tris, ground.min(axis=0), ground.max(axis=0), leaves)[1]))
    rays = [(np.array([0.3, 1.3]), unit([0.05, -1.0]), (0.45, 1.1)),
            (np.array([-2.3, 0.1]), unit([1.0, slope]), (-2.3, 0.25))]
    draw_tested_rays(ax, rays, tris, leaves)
    ax.set_title("grazing: a ray along the surface crosses leaf after leaf")
    frame(ax, np.array([-2.4, -0.4]), np.array([2.2, 1.4]), pad=0.05)
    return save(fig, "where_work_goes", "grazing.png")


def thin_triangle_box():
    """A long thin diagonal triangle: its box is almost all empty, and every ray through it tests it."""
    thin = [np.array([[-1.8, -1.2], [1.8, 1.2], [1.75, 1.3]])]
    fat = fan_triangles(blob((1.0, -0.55), 0.4, 9, 4))
    tris = thin + fat
    leaves = [(t.min(axis=0), t.max(axis=0), [i]) for i, t in enumerate(tris)]  # a leaf per triangle
    fig, (ax,) = new_figure(1, width=6.4, height=4.2)
    draw_triangles(ax, fat, lw=0.5)
    draw_triangles(ax, thin, face="#fdd49e", edge="#e6550d", lw=1.2)
    draw_box(ax, thin[0].min(axis=0), thin[0].max(axis=0), color="#e6550d", lw=1.5, ls="--")
    along = unit(thin[0][1] - thin[0][0])
    rays = [(np.array([-2.4, -0.85]), along, (-2.6, -1.05)),   # beside the triangle, all through its box
            (np.array([2.6, -0.5]), unit([-1, 0.0]), (1.9, -0.4))]
    draw_tested_rays(ax, rays, tris, leaves)
    ax.text(-1.7, 0.9, "the thin triangle's box:\nalmost all empty", fontsize=10.5, color="#e6550d")
    ax.set_title("a long thin triangle: a big box that rays enter and miss")
    frame(ax, np.array([-2.7, -1.4]), np.array([2.2, 1.45]), pad=0.05)
    return save(fig, "where_work_goes", "thin_triangles.png")


DIAGRAMS = [aabb_bounding_box, aabb_ray_cases, quadtree_depths, vertex_rule_vs_sat, separating_axis,
            octree_ray_statuses, bvh_boxes_and_tree, bvh_traversal, race_work_per_ray, leaking_ray,
            shadow_acne, silhouette_work, grazing_ray, thin_triangle_box]

if __name__ == "__main__":
    for draw in DIAGRAMS:
        print(draw())
