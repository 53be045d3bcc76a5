"""The tree view's layout (raylab.tree_layout): each node's place in the picture of a tree."""
import numpy as np
import pytest

from raylab import tree_layout

#        0
#      /   \
#     1     2
#    / \   / \
#   3   4 5   6
#        / \
#       7   8
PARENT = np.array([-1, 0, 0, 1, 1, 2, 2, 5, 5])


def test_every_node_is_shown_in_depth_first_order_with_its_row():
    picture = tree_layout.layout(tree_layout.Children(PARENT))
    assert picture["nodes"].tolist() == [0, 1, 3, 4, 2, 5, 7, 8, 6]
    assert picture["row"].tolist() == [0, 1, 2, 2, 1, 2, 3, 3, 2]
    assert not picture["collapsed"].any()
    assert picture["places"] == 5  # the five leaves side by side


def test_leaves_take_places_left_to_right_and_parents_sit_over_their_children():
    picture = tree_layout.layout(tree_layout.Children(PARENT))
    x = dict(zip(picture["nodes"].tolist(), picture["x"].tolist()))
    leaves = [3, 4, 7, 8, 6]
    assert [x[n] for n in leaves] == sorted(x[n] for n in leaves)
    assert np.allclose(np.diff([x[n] for n in leaves]), 1 / 5)
    for node in (0, 1, 2, 5):
        kids = np.flatnonzero(PARENT == node)
        assert x[node] == pytest.approx((x[kids.min()] + x[kids.max()]) / 2)
    for a, b in picture["edges"]:  # every edge joins a node to its parent, one row apart
        assert PARENT[picture["nodes"][b]] == picture["nodes"][a]
        assert picture["row"][b] == picture["row"][a] + 1


def test_levels_collapse_what_lies_deeper_and_focus_shows_one_subtree():
    children = tree_layout.Children(PARENT)
    shallow = tree_layout.layout(children, levels=1)
    assert shallow["nodes"].tolist() == [0, 1, 2]
    assert shallow["collapsed"].tolist() == [False, True, True]
    sub = tree_layout.layout(children, focus=5)
    assert sub["nodes"].tolist() == [5, 7, 8] and sub["row"].tolist() == [0, 1, 1]
    assert not sub["collapsed"].any()


def test_a_click_picks_the_nearest_node_within_its_radius():
    picture = tree_layout.layout(tree_layout.Children(PARENT))
    xs, ys = tree_layout.positions(picture, 400, 300)
    for i, node in enumerate(picture["nodes"]):
        assert tree_layout.nearest(picture, xs[i] + 2, ys[i] - 2, 400, 300, radius=6) == node
    assert tree_layout.nearest(picture, -50, -50, 400, 300, radius=6) is None
    assert ys[0] > ys[1]  # the focus at the top


@pytest.mark.parametrize("parent, message", [
    ([0, 0], "one root"), ([-1, -1], "one root"), ([-1, 5], "past the last node"), ([], "non-empty")])
def test_a_broken_parent_array_is_refused_with_a_reason(parent, message):
    with pytest.raises(ValueError, match=message):
        tree_layout.Children(np.array(parent, dtype=np.int64))


def test_a_deep_chain_is_laid_out_without_recursion():
    parent = np.arange(-1, 5000)  # node i's parent is i - 1: 5001 levels
    picture = tree_layout.layout(tree_layout.Children(parent))
    assert len(picture["nodes"]) == 5001 and picture["places"] == 1
    assert np.allclose(picture["x"], 0.5)


def test_below_is_every_node_of_the_subtree_shallowest_first():
    """Children.below lists a subtree by levels with numpy (issue 42 item 5: a Python walk of the dragon's
    root took seconds of a viewport draw): the same nodes as a walk, never a deeper one before a shallower."""
    rng = np.random.default_rng(3)
    parent = np.full(2000, -1)
    parent[1:] = [rng.integers(0, i) for i in range(1, 2000)]
    depth = np.zeros(2000, int)
    for i in range(1, 2000):
        depth[i] = depth[parent[i]] + 1
    children = tree_layout.Children(parent)
    for node in (0, 1, 17, 1999):
        walked, todo = [], [node]
        while todo:
            n = todo.pop()
            walked.append(n)
            todo.extend(children(n).tolist())
        below = children.below(node)
        assert sorted(below.tolist()) == sorted(walked) and below[0] == node
        assert (np.diff(depth[below]) >= 0).all()
