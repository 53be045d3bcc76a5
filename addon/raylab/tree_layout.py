"""Where each node of a tree goes in a picture of it (numpy only, no bpy): the tree view's layout.

A tree is given by its parent array (node i's parent, -1 for the root). The layout is the classic one
of a textbook figure: each level of depth a row, the leaves side by side in the order a depth-first walk
meets them, each inner node centred over its first and last child. Dense trees stay readable by showing
one subtree at a time (`focus`) down to a depth (`levels` below it): a node at the last shown level whose
children are hidden is *collapsed* and takes one place, as a leaf does.
"""
import numpy as np


class Children:
    """Each node's children, in the order of their indices: children(i) is an array."""

    def __init__(self, parent):
        parent = np.asarray(parent, dtype=np.int64)
        if parent.ndim != 1 or len(parent) == 0:
            raise ValueError("parent: a non-empty (N,) array of parent indices, -1 for the root")
        roots = np.flatnonzero(parent < 0)
        if len(roots) != 1:
            raise ValueError(f"parent: a tree has one root (parent -1), this has {len(roots)}")
        if parent.max() >= len(parent):
            raise ValueError("parent: an index past the last node")
        self.parent = parent
        self.root = int(roots[0])
        order = np.argsort(parent, kind="stable")  # children of one parent together, in index order
        self._order = order[1:]  # the root (parent -1) sorts first
        counts = np.bincount(parent[self._order], minlength=len(parent))
        self._start = np.concatenate([[0], np.cumsum(counts)])

    def __len__(self):
        return len(self.parent)

    def __call__(self, node):
        return self._order[self._start[node]:self._start[node + 1]]

    def count(self, node):
        return int(self._start[node + 1] - self._start[node])

    def below(self, node):
        """The node and every node under it, level by level (numpy per level: a Python walk of a million
        nodes is too slow; docs/bench/history.md)."""
        found, frontier = [np.array([node], dtype=np.int64)], np.array([node], dtype=np.int64)
        while len(frontier):
            starts, ends = self._start[frontier], self._start[frontier + 1]
            counts = ends - starts
            if counts.sum() == 0:
                break
            # Each frontier node's slice of _order, concatenated: start + 0, 1, ... count - 1.
            offsets = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
            frontier = self._order[np.repeat(starts, counts) + offsets].astype(np.int64)
            found.append(frontier)
        return np.concatenate(found)


def layout(children, focus=None, levels=None):
    """The picture of the subtree under `focus` (default: the root) down to `levels` levels below it (None:
    all): dict with
        nodes     (K,) int64: the shown nodes, in depth-first order (a parent before its children)
        x         (K,) float64 in (0, 1): across the picture
        row       (K,) int64: the level below focus (0 for focus itself)
        collapsed (K,) bool: a shown node whose children are hidden
        edges     (E,2) int64: (parent, child) as positions in `nodes`
        places    the number of places across (leaves and collapsed nodes)
    """
    focus = children.root if focus is None else int(focus)
    if not 0 <= focus < len(children):
        raise ValueError(f"focus: a node index in 0..{len(children) - 1}, got {focus}")
    nodes, rows, collapsed, edges = [], [], [], []
    position = {}
    stack = [(focus, 0, -1)]
    while stack:  # depth-first, children in order: push them reversed
        node, row, parent_position = stack.pop()
        position[node] = len(nodes)
        if parent_position >= 0:
            edges.append((parent_position, len(nodes)))
        nodes.append(node)
        rows.append(row)
        kids = children(node)
        hide = levels is not None and row >= levels and len(kids) > 0
        collapsed.append(hide)
        if not hide:
            stack.extend((int(k), row + 1, position[node]) for k in kids[::-1])
    nodes = np.asarray(nodes, dtype=np.int64)
    rows = np.asarray(rows, dtype=np.int64)
    collapsed = np.asarray(collapsed, dtype=bool)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    # Places: the nodes without shown children, in depth-first order; a parent then sits over the middle
    # of its first and last child (filled deepest row first, so children are placed before their parent).
    shown_children = np.bincount(edges[:, 0], minlength=len(nodes)) if len(edges) else np.zeros(len(nodes), int)
    ends = shown_children == 0
    x = np.zeros(len(nodes))
    x[ends] = np.arange(int(ends.sum())) + 0.5
    places = max(int(ends.sum()), 1)
    first = np.full(len(nodes), -1)
    last = np.full(len(nodes), -1)
    for p, c in edges:  # edges run in depth-first order: a parent's first edge is its first child
        if first[p] < 0:
            first[p] = c
        last[p] = c
    for i in np.argsort(-rows, kind="stable"):
        if not ends[i]:
            x[i] = 0.5 * (x[first[i]] + x[last[i]])
    return dict(nodes=nodes, x=x / places, row=rows, collapsed=collapsed, edges=edges, places=places)


def nearest(picture, px, py, width, height, radius):
    """The node of `picture` (a layout placed in a width x height box, rows from the top) nearest to the
    point (px, py) within `radius`, or None: what a click picks."""
    xs, ys = positions(picture, width, height)
    if len(xs) == 0:
        return None
    d2 = (xs - px) ** 2 + (ys - py) ** 2
    i = int(np.argmin(d2))
    return int(picture["nodes"][i]) if d2[i] <= radius * radius else None


def positions(picture, width, height, margin=12.0):
    """Pixel centres (x, y) of the picture's nodes in a width x height box, the focus row at the top."""
    rows = int(picture["row"].max()) + 1 if len(picture["row"]) else 1
    xs = margin + picture["x"] * max(width - 2 * margin, 1.0)
    step = (height - 2 * margin) / max(rows - 1, 1)
    ys = height - margin - picture["row"] * step
    return xs, ys
