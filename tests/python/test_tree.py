"""Structure.tree() and Structure.split_costs(): the tree agrees with boxes() and sah_cost(), the
explorer's chosen split is the builder's at every node of the benchmark meshes, and its candidate
costs are what a plain recomputation of the binned SAH gives."""
import math

import numpy as np
import pytest

import raylab
from conftest import load

BENCHMARK_MESHES = ("goathead", "bunny", "dragon")
BINS = 16            # the builder's bins per axis (bvh_build.cpp kBins)
SORTED_MAX = 16      # nodes up to this size sweep every split between sorted centroids (kObjectSweepMax)


@pytest.mark.parametrize("builder", raylab.BUILDERS)
def test_the_tree_is_the_boxes_and_its_costs_sum_to_sah_cost(builder):
    s = raylab.build(*load("bunny"), "bvh", builder=builder)
    tree, boxes = s.tree(), s.boxes()
    n = tree["node_count"]
    assert n == len(boxes["depth"])
    for key in ("lo", "hi", "depth", "leaf", "triangle_count"):
        assert np.array_equal(tree[key], boxes[key]), key
    assert math.isclose(tree["sah_cost"].sum(), s.sah_cost(), rel_tol=1e-9)
    children, parent, width = tree["children"], tree["parent"], tree["width"]
    assert children.shape == (len(children), width) and width in (4, 8)
    assert parent[0] == -1 and (parent[1:] >= 0).all()
    rows, slots = np.nonzero(children >= 0)
    assert np.array_equal(np.sort(children[rows, slots]), np.arange(1, n))  # every node but the root once
    assert np.array_equal(parent[children[rows, slots]], rows)
    assert np.array_equal(tree["depth"][1:], tree["depth"][parent[1:]] + 1)
    assert not tree["leaf"][:len(children)].any() and tree["leaf"][len(children):].all()
    # A node's triangles are its children's.
    counts = np.where(children >= 0, tree["triangle_count"][np.maximum(children, 0)], 0).sum(axis=1)
    assert np.array_equal(counts, tree["triangle_count"][:len(children)])


def test_every_node_a_story_visits_is_in_the_tree():
    vertices, triangles = load("bunny")
    s = raylab.build(vertices, triangles)
    tree = s.tree()
    centre = (vertices.min(0) + vertices.max(0)) / 2
    for k in range(20):
        story = s.story(centre + np.array([3.0, 0.1 * k, 0.05 * k]), np.array([-1.0, 0.0, 0.0]))
        boxes, nodes = story.boxes, np.asarray(story.nodes)
        assert ((boxes["node"] >= 0) & (boxes["node"] < tree["node_count"])).all()
        assert np.array_equal(tree["lo"][boxes["node"]], boxes["lo"])
        assert np.array_equal(tree["depth"][boxes["node"]], boxes["depth"])
        assert ((nodes >= 0) & (nodes < tree["node_count"])).all()
        # Each visited node but the root is entered from its parent, visited before it.
        assert all(tree["parent"][n] in nodes[:i] for i, n in enumerate(nodes) if i)


def test_the_octree_gives_its_nodes_and_other_kinds_refuse():
    s = raylab.build(*load("sphere"), "octree")
    tree, boxes = s.tree(), s.boxes()
    assert tree["width"] == 8 and tree["sah_cost"] is None
    assert np.array_equal(tree["depth"], boxes["depth"])
    inner = np.flatnonzero(~tree["leaf"])
    assert (tree["children"][tree["leaf"]] == -1).all() and (tree["children"][inner] >= 0).any(axis=1).all()
    with pytest.raises(ValueError, match="split_costs is the BVH's"):
        s.split_costs(0)
    for kind in ("none", "aabb", "grid"):
        with pytest.raises(ValueError, match=f"structure '{kind}' has no tree"):
            raylab.build(*load("sphere"), kind).tree()
    with pytest.raises(ValueError, match="node must be"):
        raylab.build(*load("sphere")).split_costs(10 ** 7)
    with pytest.raises(ValueError, match="node"):
        raylab.build(*load("sphere")).split_costs(-1)


def check_decisions(s):
    """At every node: leaves are leaves, and a split's left side is a prefix of the node's children."""
    tree = s.tree()
    children, counts = tree["children"], tree["triangle_count"]
    methods = set()
    for node in range(tree["node_count"]):
        c = s.split_costs(node)
        methods.add(c["method"])
        assert c["count"] == counts[node]
        assert np.array_equal(c["lo"], tree["lo"][node]) and np.array_equal(c["hi"], tree["hi"][node])
        if node >= len(children) or c["method"] == "leaf":
            assert c["method"] == "leaf" and c["cost"] == c["leaf_cost"], node
            assert node >= len(children) or (node == 0 and children[0, 1] == -1)
            continue
        prefix = np.cumsum(counts[children[node][children[node] >= 0]])
        assert len(c["left_triangles"]) in prefix[:-1], node
        if c["method"].startswith("sah"):
            axis, k = c["axis"], c["candidate"]
            assert c["costs"][axis, k] == np.float32(c["cost"]) and c["costs"].min() == c["costs"][axis, k]
            assert c["left_counts"][axis, k] == len(c["left_triangles"])
    return methods


@pytest.mark.parametrize("name", BENCHMARK_MESHES)
def test_the_explorers_split_is_the_builders_at_every_node(name):
    methods = check_decisions(raylab.build(*load(name)))
    assert {"leaf", "sah_binned", "sah_sorted"} <= methods


@pytest.mark.parametrize("builder", [b for b in raylab.BUILDERS if b != "sah"])
def test_the_other_builders_decisions_are_explained_too(builder):
    methods = check_decisions(raylab.build(*load("goathead"), builder=builder))
    assert methods - {"leaf", "index_median"} == {dict(median="object_median", lbvh="morton").get(builder, builder)}


def sah_candidates(vertices, triangles, ids):
    """The binned SAH's candidates over triangles `ids`, recomputed in float32 numpy: (positions, costs,
    left counts), each (3, K)."""
    corners = vertices[triangles[ids]]
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    c2 = lo + hi  # twice the centroids, as the builder bins them
    block, visit = raylab.SAH_CONSTANTS["leaf_block"], raylab.SAH_CONSTANTS["node_visit"]

    def half_area(low, high):
        e = (high - low).astype(np.float64)
        return e[0] * e[1] + e[1] * e[2] + e[2] * e[0]

    node_area = half_area(lo.min(0), hi.max(0))
    n = len(ids)

    def cost(left):
        nl = int(left.sum())
        if nl in (0, n):
            return math.inf
        right = ~left
        return visit + (half_area(lo[left].min(0), hi[left].max(0)) * math.ceil(nl / block) +
                        half_area(lo[right].min(0), hi[right].max(0)) * math.ceil((n - nl) / block)) / node_area

    positions, costs, lefts = [], [], []
    for a in range(3):
        p, c, k = [], [], []
        if n <= SORTED_MAX:
            order = np.lexsort((ids, c2[:, a]))  # by centroid, ties by triangle index
            for i in range(1, n):
                left = np.zeros(n, bool)
                left[order[:i]] = True
                p.append(0.25 * (c2[order[i - 1], a] + c2[order[i], a]))
                c.append(cost(left))
                k.append(i)
        else:
            origin, extent = c2[:, a].min(), c2[:, a].max() - c2[:, a].min()
            scale = np.float32(BINS) / extent
            bins = np.clip(((c2[:, a] - origin) * scale).astype(np.int32), 0, BINS - 1)
            for i in range(1, BINS):
                left = bins < i
                p.append(np.float32(0.5) * (origin + np.float32(i) / scale))
                c.append(cost(left))
                k.append(int(left.sum()))
        positions.append(p)
        costs.append(c)
        lefts.append(k)
    return np.array(positions, np.float32), np.array(costs), np.array(lefts)


@pytest.mark.parametrize("size", [5, 16, 17, 300, None])
def test_split_costs_agree_with_a_plain_recomputation(size):
    vertices, triangles = load("bunny")
    triangles = triangles[:size]
    s = raylab.build(vertices, triangles, leaf_size=1)
    c = s.split_costs(0)
    assert c["candidates"] == ("sorted" if len(triangles) <= SORTED_MAX else "binned")
    positions, costs, lefts = sah_candidates(vertices, triangles, np.arange(len(triangles)))
    assert np.array_equal(c["left_counts"], lefts)
    np.testing.assert_allclose(c["positions"], positions, rtol=1e-6)
    assert np.array_equal(np.isinf(c["costs"]), np.isinf(costs))
    np.testing.assert_allclose(c["costs"][np.isfinite(costs)], costs[np.isfinite(costs)], rtol=1e-5)
    assert c["leaf_cost"] == math.ceil(len(triangles) / raylab.SAH_CONSTANTS["leaf_block"])
    # The chosen split is the cheapest, and it is the one the builder made.
    axis, k = c["axis"], c["candidate"]
    assert c["method"].startswith("sah") and costs[axis, k] == pytest.approx(costs.min(), rel=1e-6)
    left = np.flatnonzero(np.isin(np.arange(len(triangles)), c["left_triangles"]))
    assert len(left) == lefts[axis, k]
