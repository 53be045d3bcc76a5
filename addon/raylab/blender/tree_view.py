"""The tree view: the active object's structure drawn as a tree over the 3D viewport, a node picked with a
click (or walked to with the arrow keys and the sidebar's buttons), its box and its subtree's boxes drawn
bright in the view with the rest dimmed, and, for a BVH node, the split explorer: the binned SAH cost of
every candidate split along each axis, the builder's choice marked.

The numbers come from the core (Structure.tree(), Structure.split_costs(node)); they are read outside the
panels' draws (the viewport's draw handlers and the operators), which must not call the core: see
levels.available_levels for why.
"""
import hashlib

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty

from .. import api, sah_cost, tree_layout
from . import draw, level_panels, overlay, structure_cache, text_fit, viewport_panels

COLOURS = (
    ("DEPTH", "Depth", "Each node in the colour of its depth, as the overlay draws its box"),
    ("SAH", "SAH cost", "The SAH cost below each node (its own and its subtree's) against the costliest of its "
                        "depth: cold (cheap) to hot"),
    ("TRIANGLES", "Triangles", "Each node's triangles against the most of its depth: cold (few) to hot (many)"),
)
TREE_DIM = 0.25  # the other boxes' alpha while a node is picked: its own boxes stand out
PICKED = (1.0, 1.0, 1.0, 1.0)
SUBTREE = (1.0, 0.85, 0.3, 0.9)
CHILD_COLOURS = ((0.3, 0.8, 1.0, 1.0), (1.0, 0.45, 0.75, 1.0))  # the chosen split's two children
AXIS_COLOURS = ((1.0, 0.2, 0.2, 1.0), (0.4, 1.0, 0.4, 1.0), (0.25, 0.4, 1.0, 1.0))  # x, y, z
LEAF_LINE = (0.6, 0.6, 0.6, 0.9)  # the chart's line at the cost of keeping the node a leaf
MARGIN = 16      # pixels between the view's edge and the tree's frame
MIN_PLACE = 4    # pixels a place across the tree's picture needs at least (a node's smallest square)
NODE_SIZE = 9    # a node's square, in pixels, at most
CLICK_RADIUS = 10
TITLE_HEIGHT = 22  # the frame's title row above the tree
NODE_EDGE = (0.55, 0.55, 0.55, 1.0)


class TreeSettings(bpy.types.PropertyGroup):
    enabled: BoolProperty(name="Tree View", default=False, update=lambda self, context: draw.tag_redraw(context),
                          description="Draw the active object's structure as a tree over the viewport; click a "
                                      "node to see its box")
    node: IntProperty(name="Node", default=0, min=0, update=lambda self, context: _on_pick(self, context),
                      description="The picked node (its index in Structure.tree()); a new tree (another "
                                  "Builder, mesh or leaf size) picks its root")
    focus: IntProperty(name="Focus", default=0, min=0, update=lambda self, context: _on_pick(self, context),
                       description="The node the tree view starts from (0: the root)")
    levels: IntProperty(name="Levels", default=3, min=1, max=24, update=lambda self, context: draw.tag_redraw(context),
                        description="How many levels below the focus the tree view shows; deeper nodes are "
                                    "collapsed into their ancestor")
    colour: EnumProperty(name="Colour", items=COLOURS, default="DEPTH",
                         update=lambda self, context: draw.tag_redraw(context),
                         description="What a node's colour tells")
    explorer: BoolProperty(name="Split Explorer", default=True, update=lambda self, context: draw.tag_redraw(context),
                           description="BVH: the SAH cost of every candidate split of the picked node")
    # What a level's tasks read (read-only; from the tree last read, never calling the core).
    picked_costliest: BoolProperty(name="Costliest Leaf Picked", get=lambda self: _picked_costliest(self.id_data),
                                   description="The picked node is the tree's costliest leaf, where the costliest "
                                               "path ends: from the root, the child holding the costliest leaf")
    split_shown: BoolProperty(name="Split Shown", get=lambda self: _split_shown(self.id_data),
                              description="The Split Explorer shows the picked node's candidate splits")
    cost_over_sah: FloatProperty(name="Cost over SAH's", get=lambda self: _cost_over_sah(self.id_data),
                                 description="The tree's SAH cost over the SAH builder's on the same mesh "
                                             "(0 until both are known)")


# --- the tree of a structure (read outside draws) ------------------------------------------------------

class Tree:
    """A structure's tree as the core gives it, with what the view needs: each node's children, its
    subtree, its share of the tree's cost."""

    def __init__(self, key, structure):
        self.key = key
        self.kind = structure.structure
        arrays = grid_tree(structure.boxes()) if self.kind == "grid" else structure.tree()
        self.parent = np.asarray(arrays["parent"], dtype=np.int64)
        self.depth = np.asarray(arrays["depth"])
        self.lo, self.hi = np.asarray(arrays["lo"]), np.asarray(arrays["hi"])
        self.triangle_count = np.asarray(arrays["triangle_count"])
        self.has_sah = arrays["sah_cost"] is not None  # the octree has no SAH cost
        self.sah_cost = (np.asarray(arrays["sah_cost"], dtype=np.float64) if self.has_sah
                         else np.zeros(len(self.parent)))
        self.children = tree_layout.Children(self.parent)
        # In triangle tests per ray through the root (sah_cost.py): each node's cost with its subtree's,
        # and the leaf below each node that costs the most, which Costliest walks to.
        self.cost_below = sah_cost.subtree_costs(self.parent, self.depth, sah_cost.in_tests(self.sah_cost))
        self.total_cost = float(self.cost_below[self.children.root])
        self.costliest_leaf = sah_cost.costliest_leaves(self.parent, self.depth,
                                                        np.bincount(self.parent[self.parent >= 0],
                                                                    minlength=len(self)) == 0, self.sah_cost)
        extent = np.maximum(self.hi - self.lo, 0.0).astype(np.float64)
        self.area = 2.0 * (extent[:, 0] * extent[:, 1] + extent[:, 1] * extent[:, 2] + extent[:, 2] * extent[:, 0])
        self._splits = {}
        self._pictures = {}
        self._subtree = (None, None)
        self.cost = self.sah_reference = None  # Structure.sah_cost() of this tree and of the SAH builder's
        # Names the tree's shape: a refit keeps it (and so the pick), a Builder switch or a new mesh not.
        self.shape = hashlib.blake2b(self.parent.tobytes() + self.triangle_count.tobytes()
                                     + self.kind.encode(), digest_size=16).digest()

    def __len__(self):
        return len(self.parent)

    def node(self, index):
        """A valid node index near `index` (a tree rebuilt smaller keeps the view working)."""
        return int(min(max(index, 0), len(self) - 1))

    def subtree(self, node):
        """The node and every node below it, shallowest first (the last asked kept: the view draws it every
        frame)."""
        if self._subtree[0] != node:
            self._subtree = (node, self.children.below(node))
        return self._subtree[1]

    def costliest_child(self, node):
        """The child holding the node's costliest leaf (None for a leaf): followed from the root, the
        path ends on the tree's costliest leaf."""
        kids = self.children(node)
        if len(kids) == 0 or not self.has_sah:
            return None
        return int(kids[np.flatnonzero(self.costliest_leaf[kids] == self.costliest_leaf[node])[0]])

    def picture(self, focus, levels):
        key = (focus, levels)
        if key not in self._pictures:
            if len(self._pictures) >= 8:
                self._pictures.clear()
            self._pictures[key] = tree_layout.layout(self.children, focus, levels)
        return self._pictures[key]

    def fitting_levels(self, focus, levels, width):
        """The most levels, up to `levels`, whose picture from `focus` gives each place across at least
        MIN_PLACE pixels of `width` (Levels 5 on the armadillo drew rows 3 to 5 as one grey band)."""
        while levels > 1 and self.picture(focus, levels)["places"] * MIN_PLACE > width:
            levels -= 1
        return levels

    def splits(self, node, structure):
        """Structure.split_costs(node) for an inner BVH node, else None; with what the view draws: each
        candidate's place across the node's box (0 to 1), and the chosen split's two child boxes (the
        wide node's children it puts left, a prefix of them, and the rest)."""
        if self.kind != "bvh" or self.children.count(node) == 0:
            return None
        if node not in self._splits:
            splits = dict(structure.split_costs(node))
            lo, hi = np.asarray(splits["lo"], np.float64), np.asarray(splits["hi"], np.float64)
            extent = np.where(hi > lo, hi - lo, 1.0)
            positions = np.asarray(splits["positions"], np.float64)
            splits["across"] = (positions - lo[:, None]) / extent[:, None]
            axis = splits["axis"]
            splits["across_chosen"] = float((splits["position"] - lo[axis]) / extent[axis]) if axis >= 0 else 0.0
            kids = self.children(node)
            left = int(np.searchsorted(np.cumsum(self.triangle_count[kids]), len(splits["left_triangles"])) + 1)
            sides = (kids[:left], kids[left:])
            splits["child_boxes"] = [(self.lo[side].min(axis=0), self.hi[side].max(axis=0)) for side in sides
                                     if len(side)]
            self._splits[node] = splits
        return self._splits[node]

    def known_splits(self, node):
        """The splits of `node` as splits() made them, or None when not yet made (draws must not make them:
        the core lets go of the interpreter lock)."""
        return self._splits.get(node)


def grid_tree(boxes):
    """The grid as a tree of one level (the core gives it none: its cells are not nested): the grid's box,
    then its occupied cells, the fullest first. Node ids are this order, not boxes()'s."""
    cells = np.flatnonzero(boxes["depth"] > 0)
    order = np.concatenate([np.flatnonzero(boxes["depth"] == 0)[:1],
                            cells[np.argsort(-boxes["triangle_count"][cells], kind="stable")]])
    parent = np.zeros(len(order), dtype=np.int32)
    parent[0] = -1
    return dict(parent=parent, depth=boxes["depth"][order], lo=boxes["lo"][order], hi=boxes["hi"][order],
                triangle_count=boxes["triangle_count"][order], sah_cost=None)


class NoTree:
    """What a structure without a tree gives: why (the core's words)."""

    def __init__(self, key, why):
        self.key, self.why = key, why


_trees = {}  # object name -> Tree or NoTree


def target(context):
    """The object the tree view shows: the active object if its structure is built, else the first shown
    object with one; (object, Entry) or (None, why not)."""
    scene = context.scene
    objects = structure_cache.target_objects(scene, context.view_layer)
    active = context.view_layer.objects.active
    ordered = ([active] if active in objects else []) + [o for o in objects if o != active]
    for obj in ordered:
        entry = structure_cache.cached(obj, scene)
        if entry is not None and entry.structure is not None:
            return obj, entry
    return None, "No shown mesh with a structure built yet"


def tree_of(obj, entry, scene):
    """The Tree of the object's structure, read from the core once per build, with the SAH builder's cost
    on the same mesh beside it (calls the core: never from a panel's draw)."""
    tree = _trees.get(obj.name_full)
    if tree is not None and tree.key == entry.key:
        if isinstance(tree, NoTree):
            raise ValueError(tree.why)
        _last_read[scene.name_full] = tree
        return tree
    try:
        tree = _trees[obj.name_full] = Tree(entry.key, entry.structure)
    except ValueError as error:  # a kind without a tree (the AABB): said once per build
        _trees[obj.name_full] = NoTree(entry.key, str(error))
        raise
    tree.cost = entry.structure.sah_cost()  # None for a kind without an SAH cost
    if tree.cost is not None and entry.structure.builder == api.DEFAULTS["builder"]:
        tree.sah_reference = tree.cost
    elif tree.cost is not None:  # the same mesh and settings, the default builder
        vertices, triangles = entry.structure.mesh()
        reference = api.build(vertices, triangles, structure=tree.kind, leaf_size=entry.structure.leaf_size,
                              contract=entry.structure.contract)
        tree.sah_reference = reference.sah_cost()
    _last_read[scene.name_full] = tree
    return tree


_last_read = {}  # scene name -> the Tree the view last read there (what the tasks' properties look at)
_picks = {}  # scene name -> (the shape of the tree the node and focus were picked in, node, focus)


def _on_pick(settings, context):
    """The node or focus was set (an operator, a click, a level, a script): it names a node of the tree
    the view reads now."""
    scene = settings.id_data
    tree = _last_read.get(scene.name_full)
    _picks[scene.name_full] = (None if tree is None else tree.shape, settings.node, settings.focus)
    draw.tag_redraw(context)


def picked(scene, tree):
    """(picked node, focus, reset) of `tree`: scene.raylab_tree's node and focus while the tree has the shape
    they were picked in; its root once the tree changed (a Builder switch, a mesh swap, a leaf size: node
    183 of another tree is another place), `reset` then True. A refit keeps the shape, and so the pick."""
    settings = scene.raylab_tree
    shape, node, focus = _picks.get(scene.name_full, (None, None, None))
    if (node, focus) != (settings.node, settings.focus) or shape is None:
        # Set without the update (an undo, a file just loaded): picked in the tree read now.
        _picks[scene.name_full] = (tree.shape, settings.node, settings.focus)
    elif shape != tree.shape:
        root = tree.children.root
        return root, root, (settings.node, settings.focus) != (root, root)
    return tree.node(settings.node), tree.node(settings.focus), False


def settle_pick(scene, tree):
    """Writes the root as node and focus if the tree changed since they were picked (operators only: a draw
    may not write), so that a step from there starts at the root and keeps the view where it was drawn."""
    node, focus, reset = picked(scene, tree)
    if reset:
        scene.raylab_tree.node, scene.raylab_tree.focus = node, focus
    return node


def _picked_costliest(scene):
    tree = _last_read.get(scene.name_full)
    if tree is None:
        return False
    return bool(tree.has_sah and picked(scene, tree)[0] == tree.costliest_leaf[tree.children.root])


def _split_shown(scene):
    tree = _last_read.get(scene.name_full)
    settings = scene.raylab_tree
    return (tree is not None and settings.enabled and settings.explorer
            and tree.known_splits(picked(scene, tree)[0]) is not None)


def _cost_over_sah(scene):
    tree = _last_read.get(scene.name_full)
    if tree is None or not tree.sah_reference:
        return 0.0
    return float(tree.cost / tree.sah_reference)


def known_tree(context):
    """(object, Tree) as last read, without calling the core (what the panel's draw asks), or (None, why)."""
    obj, entry = target(context)
    if obj is None:
        return None, entry
    tree = _trees.get(obj.name_full)
    if tree is None or tree.key != entry.key:
        return None, "The tree is read when the viewport draws"
    if isinstance(tree, NoTree):
        return None, tree.why
    return obj, tree


# --- the picture over the viewport -----------------------------------------------------------------------

def frames(region):
    """The tree's and the split explorer's rectangles (x, y, width, height) in the region, bottom left up."""
    width = max(200, min(int(region.width * 0.5), 900))
    height = max(120, min(int(region.height * 0.36), 320))
    tree = (MARGIN, MARGIN, width, height)
    chart_width = max(160, min(int(region.width * 0.22), 380))
    chart = (MARGIN * 2 + width, MARGIN, chart_width, height)
    return tree, chart


def shown_focus(tree, focus, picked, levels, shown=None):
    """The node the picture starts from: `shown` (where the picture last started) while the picked node is
    still in it and it lies under the focus, so that a step up (the parent arrow) keeps the picture;
    else the focus, unless the picked node lies outside what it shows; then the picked node's ancestor
    `levels - 1` above it, so that the pick is on the bottom row."""
    ancestors = [picked]
    while tree.parent[ancestors[-1]] >= 0:
        ancestors.append(int(tree.parent[ancestors[-1]]))
    if shown is not None and shown in ancestors and ancestors.index(shown) <= levels and focus in ancestors \
            and ancestors.index(focus) >= ancestors.index(shown):
        return shown
    if focus in ancestors and ancestors.index(focus) <= levels:
        return focus
    return ancestors[min(levels - 1, len(ancestors) - 1)]


def node_colours(tree, nodes, mode):
    if mode == "DEPTH":
        palette = overlay.DEPTH_PALETTE_RGBA
        return palette[tree.depth[nodes] % len(palette)]
    values = tree.cost_below[nodes] if mode == "SAH" else tree.triangle_count[nodes].astype(np.float64)
    # Against the largest of the same depth: a node's cost falls with its depth (its box's area), so one
    # scale for all would leave everything below the root cold. The square root spreads the small values.
    depth = tree.depth[nodes]
    top = np.zeros(int(depth.max()) + 1 if len(depth) else 1)
    np.maximum.at(top, depth, values)
    share = np.divide(values, top[depth], out=np.zeros_like(values), where=top[depth] > 0)
    return api.heat_map(np.sqrt(share), maximum=1.0).astype(np.float32)


_shown = {}  # region pointer -> (tree frame, picture, node centres x, y), what a click is matched against
_starts = {}  # region pointer -> (the Tree, the focus, the node its picture last started from): shown_focus's `shown`


def _draw_tree_view():
    context = bpy.context
    settings = context.scene.raylab_tree
    if not settings.enabled:
        return
    region = context.region
    obj, entry = target(context)
    tree_frame, chart_frame = frames(region)
    draw.pixel_frame(tree_frame)
    if obj is None:
        draw.pixel_text(tree_frame[0] + 8, tree_frame[1] + tree_frame[3] - 18, entry)
        return
    try:
        tree = tree_of(obj, entry, context.scene)
    except ValueError as error:
        draw.pixel_text(tree_frame[0] + 8, tree_frame[1] + tree_frame[3] - 18, str(error))
        return
    picked_node, focus, _ = picked(context.scene, tree)
    last = _starts.get(region.as_pointer())  # kept while the tree and the focus (Focus, All) are
    start = shown_focus(tree, focus, picked_node, settings.levels,
                        last[2] if last is not None and last[:2] == (tree, focus) else None)
    x0, y0, w, h = tree_frame
    levels = tree.fitting_levels(start, settings.levels, w)
    if levels < settings.levels:  # fewer levels: the pick stays on the picture's bottom row at most
        start = shown_focus(tree, focus, picked_node, levels)
        levels = tree.fitting_levels(start, levels, w)
    _starts[region.as_pointer()] = (tree, focus, start)
    focus = start
    picture = tree.picture(focus, levels)
    xs, ys = tree_layout.positions(picture, w, h - TITLE_HEIGHT)
    xs, ys = xs + x0, ys + y0
    _shown[region.as_pointer()] = (tree_frame, picture, xs, ys)
    nodes = picture["nodes"]
    edges = picture["edges"]
    if len(edges):
        segments = np.stack([np.stack([xs[edges[:, 0]], ys[edges[:, 0]]], 1),
                             np.stack([xs[edges[:, 1]], ys[edges[:, 1]]], 1)], 1).reshape(-1, 2)
        draw.pixel_lines(segments, (0.7, 0.7, 0.7, 0.35))
    size = float(np.clip(w / max(picture["places"], 1) * 0.8, 4.0, NODE_SIZE))
    draw.pixel_squares(xs, ys, size + 2, np.tile(np.float32(NODE_EDGE), (len(xs), 1)))  # an edge: black is a colour too
    draw.pixel_squares(xs, ys, size, node_colours(tree, nodes, settings.colour))
    collapsed = picture["collapsed"]
    if collapsed.any():  # a collapsed node: a short stem under it says that more hangs there
        stems = np.stack([np.stack([xs[collapsed], ys[collapsed] - size], 1),
                          np.stack([xs[collapsed], ys[collapsed] - size - 6], 1)], 1).reshape(-1, 2)
        draw.pixel_lines(stems, (1.0, 1.0, 1.0, 0.8))
    where = np.flatnonzero(nodes == picked_node)
    if len(where):
        i = where[0]
        draw.pixel_outline(xs[i], ys[i], size + 3, PICKED)
    fewer = f", {levels} of {settings.levels} levels (more would not fit: Focus)" if levels < settings.levels else ""
    title = (f"{api.STRUCTURE_INFO[tree.kind]['label']} of {obj.name}: {len(tree):,} nodes; "
             f"showing {len(nodes):,} below node {focus}{fewer}. Click a node.")
    draw.pixel_text(x0 + 8, y0 + h - 18, title)
    if settings.explorer:
        splits = tree.splits(picked_node, entry.structure)
        if splits is not None:
            draw.pixel_frame(chart_frame)
            _draw_chart(chart_frame, splits)


CHART_LEFT = 48     # pixels left of the plot for the cost axis's numbers
CHART_BOTTOM = 18   # pixels under the plot for the position axis's labels
CHART_TOP = 40      # pixels over the plot: the title row and the legend row
TEXT_WIDTH = draw.TEXT_WIDTH
WHITE = draw.WHITE


def chart_layout(frame, splits):
    """Where the Split Explorer draws (no bpy, so the tests read it): the plot (x, y, width, height), its
    cost range (low, high) in triangle tests, and its labels [(x, y, text, rgba)]: the title with the unit,
    a legend (x, y, z in their colours, the leaf's line, the chosen axis), the cost axis's lowest and
    highest values, the position axis from 0% to 100% across the node's box."""
    x0, y0, w, h = frame
    costs = [sah_cost.in_tests(np.asarray(c, dtype=np.float64)) for c in splits["costs"]]
    leaf = sah_cost.in_tests(splits["leaf_cost"])
    finite = np.concatenate([c[np.isfinite(c)] for c in costs] + [np.array([leaf])])
    low, high = float(finite.min()), float(finite.max())
    plot = (x0 + CHART_LEFT, y0 + CHART_BOTTOM, w - CHART_LEFT - 8, h - CHART_BOTTOM - CHART_TOP)
    axis = splits["axis"]
    labels = [(x0 + 8, y0 + h - 18, f"SAH cost in {sah_cost.UNIT}", WHITE)]
    x = x0 + 8
    legend = [("x", AXIS_COLOURS[0]), ("y", AXIS_COLOURS[1]), ("z", AXIS_COLOURS[2]), ("leaf", LEAF_LINE),
              (f"chosen: {'xyz'[axis] if axis >= 0 else 'none'}", AXIS_COLOURS[axis] if axis >= 0 else WHITE)]
    for text, colour in legend:
        labels.append((x, y0 + h - 34, text, colour))
        x += TEXT_WIDTH * (len(text) + 2)
    labels += [(x0 + 4, plot[1] - 4, f"{low:.4g}", WHITE), (x0 + 4, plot[1] + plot[3] - 8, f"{high:.4g}", WHITE),
               (plot[0], y0 + 4, "0%", WHITE),
               (plot[0] + plot[2] - TEXT_WIDTH * len("100% across"), y0 + 4, "100% across", WHITE)]
    return plot, (low, high), costs, leaf, labels


def _draw_chart(frame, splits):
    """Cost against split position (0 to 1 across the node's box) on each axis, the chosen split marked
    and the leaf cost as a grey line, with the labels of chart_layout."""
    (px0, py0, pw, ph), (low, high), costs, leaf, labels = chart_layout(frame, splits)
    span = high - low if high > low else 1.0

    def to_pixel(position, cost):
        return px0 + position * pw, py0 + (cost - low) / span * ph
    draw.pixel_lines(np.array([[px0, py0], [px0, py0 + ph], [px0, py0], [px0 + pw, py0]]), LEAF_LINE)  # the axes
    for axis in range(3):
        positions = splits["across"][axis]
        ok = np.isfinite(costs[axis])
        if ok.sum() >= 2:
            px, py = to_pixel(positions[ok], costs[axis][ok])
            points = np.stack([px, py], 1)
            draw.pixel_lines(np.stack([points[:-1], points[1:]], 1).reshape(-1, 2), AXIS_COLOURS[axis])
    lx0, ly = to_pixel(0.0, leaf)
    lx1, _ = to_pixel(1.0, leaf)
    draw.pixel_lines(np.array([[lx0, ly], [lx1, ly]]), LEAF_LINE)
    axis, position = splits["axis"], splits["across_chosen"]
    if axis >= 0:
        cx, cy = to_pixel(position, sah_cost.in_tests(splits["cost"]))
        draw.pixel_lines(np.array([[cx, py0], [cx, py0 + ph]]), AXIS_COLOURS[axis])
        draw.pixel_outline(cx, cy, 5, PICKED)
    for x, y, text, colour in labels:
        draw.pixel_text(x, y, text, colour)


# --- the picked node in the 3D view ----------------------------------------------------------------------

def _draw_picked_boxes():
    context = bpy.context
    settings = context.scene.raylab_tree
    if not settings.enabled:
        return
    obj, entry = target(context)
    if obj is None:
        return
    try:
        tree = tree_of(obj, entry, context.scene)
    except ValueError:
        return  # the tree view's frame says why
    picked_node = picked(context.scene, tree)[0]
    xray = context.scene.raylab.xray
    matrix = entry.model_matrix(obj)
    batch = subtree_batch(tree, picked_node)
    if batch is not None:
        draw.draw_batch(batch, matrix, xray)
    splits = tree.splits(picked_node, entry.structure) if settings.explorer else None
    if splits is not None and splits["axis"] >= 0:
        for (lo, hi), colour in zip(splits["child_boxes"], CHILD_COLOURS):
            _draw_boxes(np.asarray([lo]), np.asarray([hi]), colour, matrix, xray, width=2.0)
    _draw_boxes(tree.lo[[picked_node]], tree.hi[[picked_node]], PICKED, matrix, xray, width=3.0)


SUBTREE_BOXES = 20000  # at most this many of the picked node's subtree boxes drawn: the shallowest
_subtree_batch = [None, None]  # (the tree's key and shape, the node), its GPU batch: made once per pick


def drawn_subtree(tree, node, budget=SUBTREE_BOXES):
    """The picked node's subtree boxes drawn in gold: all of them, or the `budget` shallowest (the dragon's
    root has a million: the overlay draws them all already)."""
    return tree.subtree(node)[1:budget + 1]  # subtree() lists the shallowest first


def subtree_batch(tree, node):
    """The GPU batch of drawn_subtree in object space, made again only when the tree or the pick changed."""
    key = (tree.key, tree.shape, node)
    if _subtree_batch[0] != key:
        nodes = drawn_subtree(tree, node)
        batch = None
        if len(nodes):
            corners, indices = draw.box_wireframe(tree.lo[nodes].astype(np.float32), tree.hi[nodes].astype(np.float32))
            batch = draw.make_batch('LINES', corners, np.tile(np.asarray(SUBTREE, np.float32), (len(corners), 1)),
                                    indices)
        _subtree_batch[:] = [key, batch]
    return _subtree_batch[1]


def _draw_boxes(lo, hi, colour, matrix, xray, width=1.0):
    corners, indices = draw.box_wireframe(np.asarray(lo, np.float32), np.asarray(hi, np.float32))
    starts, ends = corners[indices[:, 0]], corners[indices[:, 1]]
    starts = structure_cache.transform_points(np.asarray(matrix), starts)
    ends = structure_cache.transform_points(np.asarray(matrix), ends)
    draw.draw_segments(starts, ends, np.tile(np.asarray(colour, np.float32), (len(starts), 1)), xray, width)


def dimming(scene):
    """The overlay's other boxes' alpha factor while the tree view has a node picked."""
    return TREE_DIM if scene.raylab_tree.enabled else 1.0


# --- picking and walking -----------------------------------------------------------------------------

STEPS = {
    'PARENT': "The picked node's parent", 'CHILD': "Its first child", 'NEXT': "Its next sibling",
    'PREVIOUS': "Its previous sibling", 'ROOT': "The root", 'COSTLIEST': "Its child holding its costliest leaf",
    'FOCUS': "Show the tree from the picked node down", 'UNFOCUS': "Show the whole tree again",
}


def walk(tree, node, step):
    """The node a step leads to from `node`: 'PARENT', 'CHILD' (the first), 'NEXT'/'PREVIOUS' (sibling),
    'ROOT', 'COSTLIEST' (the child holding the costliest leaf); the node itself where there is none."""
    if step == 'ROOT':
        return 0
    parent = int(tree.parent[node])
    if step == 'PARENT':
        return node if parent < 0 else parent
    if step == 'CHILD':
        kids = tree.children(node)
        return int(kids[0]) if len(kids) else node
    if step == 'COSTLIEST':
        child = tree.costliest_child(node)
        return node if child is None else child
    if parent < 0:
        return node
    siblings = list(tree.children(parent))
    i = siblings.index(node) + (1 if step == 'NEXT' else -1)
    return int(siblings[i]) if 0 <= i < len(siblings) else node


class RAYLAB_OT_tree_walk(bpy.types.Operator):
    """Pick the parent, a child, a sibling, the root or the child holding the costliest leaf of the picked node"""
    bl_idname = "raylab.tree_walk"
    bl_label = "Walk the Tree"
    # Undo, but not registered: Blender's Adjust Last Operation panel, opened by a registered operator,
    # covered the tree view's bottom row at the viewport's bottom left.
    bl_options = {'UNDO'}

    step: EnumProperty(items=[(s, s.title(), STEPS[s]) for s in STEPS], default='PARENT',
                       description="Where to go from the picked node")
    child: IntProperty(default=-1, description="Pick this child of the picked node (its position, from 0)")

    def execute(self, context):
        obj, entry = target(context)
        if obj is None:
            self.report({'WARNING'}, f"raylab: {entry}")
            return {'CANCELLED'}
        settings = context.scene.raylab_tree
        try:
            tree = tree_of(obj, entry, context.scene)
        except ValueError as error:
            self.report({'WARNING'}, f"raylab: {error}")
            return {'CANCELLED'}
        node = settle_pick(context.scene, tree)
        if self.child >= 0:
            kids = tree.children(node)
            if self.child < len(kids):
                settings.node = int(kids[self.child])
        elif self.step == 'FOCUS':
            settings.focus = node
        elif self.step == 'UNFOCUS':
            settings.focus = 0
        else:
            settings.node = walk(tree, node, self.step)
        return {'FINISHED'}


class RAYLAB_OT_tree_click(bpy.types.Operator):
    """Pick the tree view's node under the mouse (clicks elsewhere reach the viewport as usual)"""
    bl_idname = "raylab.tree_click"
    bl_label = "Pick a Node in the Tree View"  # the status bar shows it for the left button over the whole view
    bl_options = {'UNDO'}  # as tree_walk: no Adjust Last Operation panel over the tree

    @classmethod
    def poll(cls, context):
        return context.area is not None and context.area.type == 'VIEW_3D' and context.scene.raylab_tree.enabled

    def invoke(self, context, event):
        shown = _shown.get(context.region.as_pointer()) if context.region else None
        if shown is None:
            return {'PASS_THROUGH'}
        (x, y, w, h), picture, _, _ = shown
        mx, my = event.mouse_region_x, event.mouse_region_y
        if not (x <= mx <= x + w and y <= my <= y + h):
            return {'PASS_THROUGH'}
        node = tree_layout.nearest(picture, mx - x, my - y, w, h - TITLE_HEIGHT, CLICK_RADIUS)
        tree = _last_read.get(context.scene.name_full)
        if tree is not None:  # the picture drawn from the root of a new tree: its focus is the root too
            settle_pick(context.scene, tree)
        if node is not None:  # else inside the frame but on no node: the click is the tree view's all the same
            context.scene.raylab_tree.node = node
        return {'FINISHED'}


class RAYLAB_OT_tree_key(bpy.types.Operator):
    """Walk the tree view with the arrow keys while the mouse is over it"""
    bl_idname = "raylab.tree_key"
    bl_label = "Walk the Tree with a Key"

    step: EnumProperty(items=[(s, s.title(), STEPS[s]) for s in ('PARENT', 'CHILD', 'NEXT', 'PREVIOUS')],
                       default='PARENT', description="Where the key goes from the picked node")

    @classmethod
    def poll(cls, context):
        return RAYLAB_OT_tree_click.poll(context)

    def invoke(self, context, event):
        shown = _shown.get(context.region.as_pointer()) if context.region else None
        if shown is None:
            return {'PASS_THROUGH'}
        x, y, w, h = shown[0]
        if not (x <= event.mouse_region_x <= x + w and y <= event.mouse_region_y <= y + h):
            return {'PASS_THROUGH'}
        return bpy.ops.raylab.tree_walk(step=self.step)


# --- the sidebar panel -----------------------------------------------------------------------------------

def node_lines(tree, node, reset=False):
    """What the panel says of a node: [(text, icon)]; `reset`: the pick went back to the root as the tree
    changed (picked)."""
    kids = tree.children.count(node)
    kind = f"inner node, {kids} children" if kids else "leaf"
    share = tree.cost_below[node] / tree.total_cost if tree.total_cost > 0 else 0.0
    root_area = tree.area[0] if tree.area[0] > 0 else 1.0
    lines = [
        (f"Node {node}: depth {int(tree.depth[node])}, {kind}", 'OUTLINER_DATA_LIGHTPROBE'),
        (f"{int(tree.triangle_count[node]):,} triangles below it", 'MESH_DATA'),
        (f"Surface area {tree.area[node]:.4g} ({tree.area[node] / root_area:.1%} of the root's)", 'CUBE'),
    ]
    if tree.has_sah:
        leaf = int(tree.costliest_leaf[node])
        lines.append((f"SAH cost here and below: {tree.cost_below[node]:.4g} {sah_cost.UNIT} per ray through the "
                      f"root, {sah_cost.percent(share)} of the tree's {tree.total_cost:.4g}", 'SORTSIZE'))
        lines.append((f"As a leaf it would cost {sah_cost.leaf_tests(int(tree.triangle_count[node])):,} "
                      f"{sah_cost.UNIT} per ray into it", 'NONE'))
        if kids:
            lines.append((f"Its costliest leaf: node {leaf}, {tree.cost_below[leaf]:.3g} {sah_cost.UNIT} per ray "
                          f"through the root", 'NONE'))
    if reset:
        lines.insert(0, ("A new tree (Builder, mesh or leaf size changed): the pick went back to the root", 'INFO'))
    if tree.sah_reference and tree.cost is not None:
        lines.append((f"The tree's SAH cost {sah_cost.in_tests(tree.cost):.4g} {sah_cost.UNIT}, the SAH "
                      f"builder's {sah_cost.in_tests(tree.sah_reference):.4g}", 'INFO'))
    return lines


class _TreePanel:
    """The Tree panel: the tree view's checkbox in its header, its settings and the picked node."""
    bl_label = "Tree"

    def draw_header(self, context):
        self.layout.prop(context.scene.raylab_tree, "enabled", text="")

    def draw(self, context):
        settings = context.scene.raylab_tree
        layout = self.layout
        column = layout.column(align=True)
        column.prop(settings, "colour")
        column.prop(settings, "levels")
        layout.prop(settings, "explorer")
        draw_picked_node(layout, context)


def in_level(context):
    """Whether the open level teaches with the tree view (it sets the tree view's settings, as Why SAH?
    does): there the Tree panel is the level's, right under its tasks."""
    level = level_panels.current_level(context)
    return level is not None and bool(level.settings.get("raylab_tree"))


class RAYLAB_PT_tree(_TreePanel, viewport_panels.SidebarPanel, bpy.types.Panel):
    """The Tree panel of the sidebar's raylab tab, closed at its bottom: the structures' other panels come
    first. Hidden in a level that teaches the tree, where RAYLAB_PT_level_tree shows it."""
    bl_options = {'DEFAULT_CLOSED'}

    @classmethod
    def poll(cls, context):
        return not in_level(context)


class RAYLAB_PT_level_tree(_TreePanel, level_panels.OpenLevelPanel, bpy.types.Panel):
    """The Tree panel where a level that teaches the tree needs it: a sub-panel of Levels, right under the
    Tasks (level_panels.TASKS_ORDER + 1) and open the first time it shows. Blender keeps its open or closed
    state in the screen, so a student who closes it finds it closed when the level opens again."""
    bl_order = level_panels.TASKS_ORDER + 1

    @classmethod
    def poll(cls, context):
        return in_level(context)


def draw_picked_node(layout, context):
    """The picked node's lines, the walk buttons and its split (the Tree panel's)."""
    obj, tree = known_tree(context)
    if obj is None:
        text_fit.label(layout, context, tree, 'INFO')
        return
    node, _, reset = picked(context.scene, tree)
    box = layout.box()
    for text, icon in node_lines(tree, node, reset):
        text_fit.label(box, context, text, icon, boxes=1)
    row = layout.row(align=True)
    for step, icon in (('PARENT', 'TRIA_UP'), ('PREVIOUS', 'TRIA_LEFT'), ('NEXT', 'TRIA_RIGHT'),
                       ('CHILD', 'TRIA_DOWN')):
        row.operator(RAYLAB_OT_tree_walk.bl_idname, text="", icon=icon).step = step
    row.operator(RAYLAB_OT_tree_walk.bl_idname, text="Costliest").step = 'COSTLIEST'
    row = layout.row(align=True)
    row.operator(RAYLAB_OT_tree_walk.bl_idname, text="Root").step = 'ROOT'
    row.operator(RAYLAB_OT_tree_walk.bl_idname, text="Focus").step = 'FOCUS'
    row.operator(RAYLAB_OT_tree_walk.bl_idname, text="All").step = 'UNFOCUS'
    splits = tree.known_splits(node)
    if splits is not None and splits["axis"] >= 0:
        method = api.SPLIT_METHOD_INFO[splits["method"]]["description"]
        text_fit.label(layout, context, f"Split along {'xyz'[splits['axis']]}, {splits['across_chosen']:.0%} "
                                        f"across the box: {method}. Per ray into this node the split costs "
                                        f"{sah_cost.in_tests(splits['cost']):.4g} {sah_cost.UNIT}, a leaf "
                                        f"{sah_cost.in_tests(splits['leaf_cost']):.4g}", 'MOD_EDGESPLIT')


CLASSES = (TreeSettings, RAYLAB_OT_tree_walk, RAYLAB_OT_tree_click, RAYLAB_OT_tree_key, RAYLAB_PT_tree,
           RAYLAB_PT_level_tree)
_handles = []
_keymaps = []


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def register():
    _register_classes()
    bpy.types.Scene.raylab_tree = PointerProperty(type=TreeSettings)
    overlay.DIMMERS.append(dimming)
    _handles.append(bpy.types.SpaceView3D.draw_handler_add(_draw_picked_boxes, (), 'WINDOW', 'POST_VIEW'))
    _handles.append(bpy.types.SpaceView3D.draw_handler_add(_draw_tree_view, (), 'WINDOW', 'POST_PIXEL'))
    keyconfig = bpy.context.window_manager.keyconfigs.addon
    if keyconfig is not None:  # None in background mode
        keymap = keyconfig.keymaps.new(name="3D View", space_type='VIEW_3D')
        _keymaps.append((keymap, keymap.keymap_items.new(RAYLAB_OT_tree_click.bl_idname, 'LEFTMOUSE', 'PRESS')))
        # The arrows go in the Frames keymap: the 3D view handles it before its own (Up and Down jump to the
        # first and last frame there); over the tree the walk takes them, anywhere else they pass through.
        frames = keyconfig.keymaps.new(name="Frames")
        for key, step in (('UP_ARROW', 'PARENT'), ('DOWN_ARROW', 'CHILD'), ('LEFT_ARROW', 'PREVIOUS'),
                          ('RIGHT_ARROW', 'NEXT')):
            item = frames.keymap_items.new(RAYLAB_OT_tree_key.bl_idname, key, 'PRESS')
            item.properties.step = step
            _keymaps.append((frames, item))


def unregister():
    for keymap, item in _keymaps:
        keymap.keymap_items.remove(item)
    _keymaps.clear()
    for handle in _handles:
        bpy.types.SpaceView3D.draw_handler_remove(handle, 'WINDOW')
    _handles.clear()
    if dimming in overlay.DIMMERS:
        overlay.DIMMERS.remove(dimming)
    del bpy.types.Scene.raylab_tree
    _unregister_classes()
    _trees.clear()
    _shown.clear()
