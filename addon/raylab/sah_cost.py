"""The SAH's one cost model, as raylab says it everywhere (the Why SAH? text and diagram, the tree view's
panel, the Split Explorer): numpy only, no bpy.

The core prices a tree with its constants (api.SAH_CONSTANTS, declared once in the core): a node visit
costs `node_visit` and a leaf ceil(triangles / leaf_block), in units of testing one block of `leaf_block`
triangles together. raylab quotes every such cost in one unit a student already counts, the probe's
**triangle tests**: the core's number times `leaf_block`. So a leaf costs its triangles, rounded up to a
whole block, and a node visit costs NODE_VISIT_TESTS triangle tests. A cost is what one ray pays on
average, counted from where it enters: the root for a tree's cost and a node's share of it, the node
itself for a split's cost and its cost as a leaf.
"""
import math

import numpy as np

from . import api

LEAF_BLOCK = int(api.SAH_CONSTANTS["leaf_block"])
NODE_VISIT = float(api.SAH_CONSTANTS["node_visit"])
NODE_VISIT_TESTS = NODE_VISIT * LEAF_BLOCK  # a node visit, in triangle tests
UNIT = "triangle tests"


def in_tests(core_cost):
    """A cost of the core's (Structure.sah_cost, tree()["sah_cost"], split_costs' costs) in triangle tests."""
    if np.ndim(core_cost):
        return np.asarray(core_cost, dtype=np.float64) * LEAF_BLOCK
    return float(core_cost) * LEAF_BLOCK


def leaf_tests(triangles):
    """What a leaf of `triangles` triangles costs a ray that enters it: its triangles, in whole blocks."""
    return LEAF_BLOCK * math.ceil(triangles / LEAF_BLOCK)


def split_tests(fractions_and_triangles):
    """The cost of a split, in triangle tests: a node visit plus, for each side, the chance a ray through
    the node enters the side's box (its area over the node's) times the side's leaf cost."""
    return NODE_VISIT_TESTS + sum(p * leaf_tests(n) for p, n in fractions_and_triangles)


def rule():
    """The rule in words, as the text and the panels say it."""
    return (f"a node visit costs {NODE_VISIT_TESTS:g} {UNIT}, a leaf its triangles rounded up to a whole "
            f"block of {LEAF_BLOCK} (tested together)")


def subtree_costs(parent, depth, own):
    """Each node's cost with everything below it: `own` (N,) summed up the tree (`parent` (N,), -1 at the
    root; `depth` (N,)), deepest level first, so that a node's value is its own cost plus its children's."""
    parent, depth = np.asarray(parent, dtype=np.int64), np.asarray(depth, dtype=np.int64)
    total = np.array(own, dtype=np.float64)
    for level in range(int(depth.max()), 0, -1):
        nodes = np.flatnonzero(depth == level)
        np.add.at(total, parent[nodes], total[nodes])
    return total


def costliest_leaves(parent, depth, leaf, own):
    """For each node, the leaf below it (itself, for a leaf) that costs the most (`own` (N,): each node's
    own cost; `leaf` (N,) bool), so that following the child that holds its parent's costliest leaf from
    the root ends on the tree's costliest leaf."""
    parent, depth = np.asarray(parent, dtype=np.int64), np.asarray(depth, dtype=np.int64)
    best = np.where(np.asarray(leaf, dtype=bool), np.asarray(own, dtype=np.float64), -np.inf)
    node = np.arange(len(parent))
    for level in range(int(depth.max()), 0, -1):
        nodes = np.flatnonzero(depth == level)
        nodes = nodes[np.argsort(best[nodes], kind="stable")]  # the costliest child is written last
        best[parent[nodes]] = best[nodes]
        node[parent[nodes]] = node[nodes]
    return node


def percent(share):
    """A share of a tree's cost as a percentage that never reads 0.0% for a leaf's small share."""
    return f"{share:.1%}" if share >= 0.001 or share == 0 else f"{100 * share:.2g}%"
