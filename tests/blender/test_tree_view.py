"""The tree view's model inside Blender (no window: the drawing is tests/gui/test_student_gui.py's): walking
the tree with the panel's buttons, what the panel says of a node, the Split Explorer's boxes, the cost
against the SAH builder's, and the kinds without a tree."""
import os

import bpy
import numpy as np
import pytest

import raylab
from raylab import sah_cost
from raylab.blender import levels, structure_cache, tree_view

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir)


@pytest.fixture
def why_sah():
    before = bpy.context.window.scene
    scene = levels.open_level(bpy.context, "why_sah")
    structure_cache.scene_model(scene)
    yield scene
    bpy.context.window.scene = before  # as the other test files expect it: their scene, no level scenes
    for level_scene in [s for s in bpy.data.scenes if levels.state(s) is not None]:
        levels._remove_scene(level_scene)


def walk(step, **more):
    return bpy.ops.raylab.tree_walk(step=step, **more)


def the_tree(scene):
    obj, entry = tree_view.target(bpy.context)
    return tree_view.tree_of(obj, entry, scene)


def test_the_buttons_walk_to_the_parent_the_children_and_the_siblings(why_sah):
    settings = why_sah.raylab_tree
    assert walk('ROOT') == {'FINISHED'} and settings.node == 0
    tree = the_tree(why_sah)
    kids = tree.children(0)
    assert len(kids) >= 2 and (tree.parent[kids] == 0).all()
    walk('CHILD')
    assert settings.node == kids[0]
    walk('NEXT')
    assert settings.node == kids[1]
    walk('PREVIOUS')
    walk('PREVIOUS')  # no sibling before the first: it stays
    assert settings.node == kids[0]
    walk('PARENT')
    walk('PARENT')  # the root has no parent: it stays
    assert settings.node == 0
    walk('PARENT', child=2)
    assert settings.node == kids[2]
    walk('ROOT')
    walk('COSTLIEST')
    assert tree.costliest_leaf[settings.node] == tree.costliest_leaf[0]  # the child holding the costliest leaf


@pytest.mark.parametrize("builder", ["sah", "median"])
def test_the_costliest_path_ends_on_the_leaf_holding_the_most_cost(why_sah, builder):
    """Follow the cost down: Costliest from the root ends on the leaf that costs rays the most (each leaf's
    own SAH cost, from the core), and every node on the way shows more of the cost below it than that leaf."""
    why_sah.raylab.builder = builder
    structure_cache.scene_model(why_sah)
    settings = why_sah.raylab_tree
    walk('ROOT')
    assert not settings.picked_costliest
    tree = the_tree(why_sah)
    path = [0]
    for _ in range(64):
        walk('COSTLIEST')
        if settings.node == path[-1]:
            break
        path.append(settings.node)
    leaves = np.flatnonzero(np.bincount(tree.parent[1:], minlength=len(tree)) == 0)
    assert tree.children.count(settings.node) == 0 and settings.picked_costliest
    assert tree.sah_cost[settings.node] == tree.sah_cost[leaves].max()
    assert all(tree.cost_below[a] >= tree.cost_below[b] for a, b in zip(path, path[1:]))
    share = [text for text, _ in tree_view.node_lines(tree, settings.node) if "of the tree's" in text][0]
    assert "0.0%" not in share and "of the tree's" in share  # a leaf's small share still reads


@pytest.mark.parametrize("change", ["builder", "mesh"])
def test_a_new_tree_picks_its_root_and_says_so(why_sah, change):
    """Issue 42 item 4: node 183 of another tree is another place (the spout under the SAH, the handle under
    the median): a Builder switch or a mesh swap picks the new tree's root, and the panel says why."""
    settings = why_sah.raylab_tree
    walk('ROOT')
    for _ in range(4):
        walk('COSTLIEST')
    tree = the_tree(why_sah)
    old = settings.node
    assert old != 0 and tree_view.picked(why_sah, the_tree(why_sah)) == (old, 0, False)  # kept while unchanged
    if change == "builder":
        why_sah.raylab.builder = "median"
    else:
        assert bpy.ops.raylab.level_swap_mesh(source="file:sphere.obj") == {'FINISHED'}
    structure_cache.scene_model(why_sah)
    new = the_tree(why_sah)
    assert new.shape != tree.shape
    assert tree_view.picked(why_sah, new) == (0, 0, True)
    assert tree_view.node_lines(new, 0, True)[0][0].startswith("A new tree")
    assert not settings.picked_costliest
    walk('CHILD')  # a step starts from the root of the new tree
    assert settings.node == new.children(0)[0] and settings.focus == 0
    assert tree_view.picked(why_sah, new) == (settings.node, 0, False)


def test_the_panel_tells_a_node_s_depth_triangles_area_and_share_of_the_cost(why_sah):
    walk('ROOT')
    tree = the_tree(why_sah)
    texts = [text for text, _ in tree_view.node_lines(tree, 0)]
    assert texts[0].startswith("Node 0: depth 0, inner node")
    assert f"{int(tree.triangle_count[0]):,} triangles" in texts[1]
    assert "100.0% of the root's" in texts[2]
    assert sum(tree.sah_cost) == pytest.approx(tree.cost)  # the shares add up to the tree's cost
    # One unit, the triangle tests (SAH_CONSTANTS' leaf block times the core's cost): the root's cost below
    # is the tree's whole cost, each inner node's is its own and its children's.
    assert tree.total_cost == pytest.approx(tree.cost * raylab.SAH_CONSTANTS["leaf_block"])
    assert f"100.0% of the tree's {tree.total_cost:.4g}" in texts[3] and "triangle tests" in texts[3]
    for node in tree.children(0):
        below = tree.sah_cost[node] * raylab.SAH_CONSTANTS["leaf_block"] + sum(
            tree.cost_below[k] for k in tree.children(int(node)))
        assert tree.cost_below[node] == pytest.approx(below)
    leaf = int(np.flatnonzero([tree.children.count(n) == 0 for n in range(len(tree))])[0])
    assert "leaf" in tree_view.node_lines(tree, leaf)[0][0]


def test_a_leaf_costs_its_triangles_in_the_panel_the_explorer_and_the_text(why_sah):
    """Item 2 of issue 42: a node of n triangles "as a leaf" costs n triangle tests (rounded up to a whole
    block of SAH_CONSTANTS' leaf_block) in the panel, in the Split Explorer's line and in the level's text."""
    obj, entry = tree_view.target(bpy.context)
    tree = the_tree(why_sah)
    block = raylab.SAH_CONSTANTS["leaf_block"]
    node = int(tree.children(0)[0])
    count = int(tree.triangle_count[node])
    as_leaf = block * -(-count // block)
    texts = [text for text, _ in tree_view.node_lines(tree, node)]
    assert f"As a leaf it would cost {as_leaf:,} triangle tests per ray into it" in texts
    splits = tree.splits(node, entry.structure)
    assert sah_cost.in_tests(splits["leaf_cost"]) == as_leaf
    visit = raylab.SAH_CONSTANTS["node_visit"] * block
    text = " ".join(open(os.path.join(ROOT, "levels", "why_sah", "text.md"), encoding="utf-8").read().split())
    assert f"a node visit costs {visit:g} triangle tests" in text
    assert f"rounded up to a whole block of {block}" in text


def test_the_split_explorer_s_child_boxes_make_up_the_node_s_box(why_sah):
    obj, entry = tree_view.target(bpy.context)
    tree = the_tree(why_sah)
    for node in [0, *tree.children(0)[:3]]:
        splits = tree.splits(int(node), entry.structure)
        if splits is None:
            continue
        (llo, lhi), (rlo, rhi) = splits["child_boxes"]
        assert np.allclose(np.minimum(llo, rlo), tree.lo[node]) and np.allclose(np.maximum(lhi, rhi), tree.hi[node])
        assert 0.0 <= splits["across_chosen"] <= 1.0 and splits["axis"] in (0, 1, 2)
        assert np.nanmin(splits["costs"][splits["axis"]]) == pytest.approx(splits["cost"], rel=1e-5)


def test_another_builder_s_tree_is_priced_against_the_sah_builder_s(why_sah):
    walk('ROOT')
    assert why_sah.raylab_tree.cost_over_sah == pytest.approx(1.0)
    why_sah.raylab.builder = "median"
    structure_cache.scene_model(why_sah)
    walk('ROOT')
    assert why_sah.raylab_tree.cost_over_sah > 1.05  # the object median's tree costs more on the teapot


def test_the_octree_has_a_tree_without_an_sah_the_grid_its_cells_and_the_aabb_none(why_sah):
    why_sah.raylab.structure = "octree"
    structure_cache.scene_model(why_sah)
    assert walk('CHILD') == {'FINISHED'}
    tree = the_tree(why_sah)
    assert not tree.has_sah and all("SAH" not in text for text, _ in tree_view.node_lines(tree, 0))
    why_sah.raylab.structure = "grid"
    structure_cache.scene_model(why_sah)
    assert walk('ROOT') == {'FINISHED'} and walk('CHILD') == {'FINISHED'}
    tree = the_tree(why_sah)
    cells = tree.children(0)
    assert len(cells) == len(tree) - 1 and (tree.depth[cells] == 1).all()  # one level: the occupied cells
    assert why_sah.raylab_tree.node == cells[0] == 1  # the fullest cell first
    assert (np.diff(tree.triangle_count[cells].astype(np.int64)) <= 0).all()
    why_sah.raylab.structure = "aabb"
    structure_cache.scene_model(why_sah)
    assert walk('CHILD') == {'CANCELLED'}
    obj, why = tree_view.known_tree(bpy.context)
    assert obj is None and "no tree" in why


@pytest.mark.parametrize("region", [(1270, 820), (950, 640)], ids=["1600x900", "1280x720"])
def test_the_split_explorer_has_labelled_axes_a_legend_and_its_unit(why_sah, region):
    """Issue 42 item 5: the explorer's chart says its unit, the costs at the bottom and top of its axis,
    where across the box a split lies, and which colour is which, every label inside the frame and none
    over another (a character of the 12 px font taken as TEXT_WIDTH wide)."""
    obj, entry = tree_view.target(bpy.context)
    tree = the_tree(why_sah)
    splits = tree.splits(0, entry.structure)
    _, chart = tree_view.frames(type("Region", (), dict(width=region[0], height=region[1]))())
    plot, (low, high), costs, leaf, labels = tree_view.chart_layout(chart, splits)
    finite = np.concatenate([c[np.isfinite(c)] for c in costs] + [[leaf]])
    assert (low, high) == (finite.min(), finite.max())
    assert leaf == sah_cost.leaf_tests(int(tree.triangle_count[0]))
    texts = {text: colour for _, _, text, colour in labels}
    assert any("triangle tests" in text for text in texts)
    assert f"{low:.4g}" in texts and f"{high:.4g}" in texts and "0%" in texts and "100% across" in texts
    assert [texts["x"], texts["y"], texts["z"], texts["leaf"]] == [*tree_view.AXIS_COLOURS, tree_view.LEAF_LINE]
    assert f"chosen: {'xyz'[splits['axis']]}" in texts
    x0, y0, w, h = chart
    boxes = [(x, y, x + tree_view.TEXT_WIDTH * len(text), y + 12) for x, y, text, _ in labels]
    for box in boxes:
        assert x0 <= box[0] and box[2] <= x0 + w and y0 <= box[1] and box[3] <= y0 + h, (box, chart)
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            assert a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1], (a, b)


def test_the_parent_arrow_keeps_the_picture_where_it_was(why_sah):
    """Issue 42 item 5: a step up from a node on the picture's bottom row kept the pick in view but started
    the picture from the root again (the whole tree, the node's neighbourhood gone): the picture keeps its
    start while the pick stays in it."""
    tree = the_tree(why_sah)
    levels = 3
    deep = int(np.flatnonzero(tree.depth == levels + 1)[0])
    start = tree_view.shown_focus(tree, 0, deep, levels)
    assert tree.depth[start] == 2  # the pick on the bottom row
    parent = int(tree.parent[deep])
    assert tree_view.shown_focus(tree, 0, parent, levels) == 0  # from nothing: the focus, the whole tree
    assert tree_view.shown_focus(tree, 0, parent, levels, shown=start) == start
    # a pick outside the picture still moves it; a start outside the focus is not kept
    other = next(int(n) for n in np.flatnonzero(tree.depth == levels + 1)
                 if tree_view.shown_focus(tree, 0, int(n), levels) != start)
    assert tree_view.shown_focus(tree, 0, other, levels, shown=start) == tree_view.shown_focus(tree, 0, other, levels)
    assert tree_view.shown_focus(tree, deep, deep, levels, shown=start) == deep


def test_in_why_sah_the_tree_panel_is_open_right_under_the_tasks(why_sah):
    """Issue 42 item 5: the Tree panel sat closed at the sidebar's bottom. In a level that teaches the tree it
    is a sub-panel of Levels, right after Tasks (bl_order) and open by default; the sidebar's own Tree panel
    steps aside there, and the Tasks panel no longer repeats the picked node or the tree's settings."""
    from raylab.blender import level_panels
    level_tree, sidebar_tree = tree_view.RAYLAB_PT_level_tree, tree_view.RAYLAB_PT_tree
    assert level_tree.bl_label == sidebar_tree.bl_label == "Tree"
    assert level_tree.bl_parent_id == level_panels.RAYLAB_PT_levels.__name__
    assert 'DEFAULT_CLOSED' not in getattr(level_tree, "bl_options", set())
    siblings = sorted((cls for cls in level_panels.CLASSES + (level_tree,)
                       if getattr(cls, "bl_parent_id", None) == level_tree.bl_parent_id), key=lambda c: c.bl_order)
    assert [c.bl_label for c in siblings][:3] == ["Tasks", "Tree", "Tutorial"]
    assert level_tree.poll(bpy.context) and not sidebar_tree.poll(bpy.context)
    assert not any(c.startswith("raylab_tree.") for c in level_panels.current_level(bpy.context).controls)
    assert all(getattr(hook, "__module__", "") != tree_view.__name__ for hook in level_panels.TASK_SECTIONS)
    levels.open_level(bpy.context, "bvh_2")  # a level that does not teach the tree: the sidebar's panel
    assert sidebar_tree.poll(bpy.context) and not level_tree.poll(bpy.context)


def test_picking_the_dragon_s_root_draws_a_bounded_shallowest_subtree():
    """Issue 42 item 5: picking the dragon's root took a 4.6 s viewport draw (a Python walk of a million nodes,
    their boxes made again every draw). The subtree is listed by levels with numpy, at most SUBTREE_BOXES of its
    boxes are drawn, the shallowest, and their batch is made once per pick (subtree_batch)."""
    path = os.path.join(ROOT, "addon", "raylab", "meshes", "dragon.obj")
    tree = tree_view.Tree(("dragon",), raylab.build_file(path, structure="bvh"))
    nodes = tree_view.drawn_subtree(tree, 0)
    assert len(tree) - 1 > tree_view.SUBTREE_BOXES == len(nodes) and 0 not in nodes
    rest = np.setdiff1d(np.arange(1, len(tree)), nodes)
    assert tree.depth[nodes].max() <= tree.depth[rest].min()  # the shallowest drawn, the deepest left out
    leaf = int(np.flatnonzero(np.bincount(tree.parent[1:], minlength=len(tree)) == 0)[0])
    assert len(tree_view.drawn_subtree(tree, leaf)) == 0


def test_levels_the_frame_cannot_hold_are_left_out_not_drawn_as_a_band():
    """Issue 42 item 5: Levels 5 on the armadillo drew rows 3 to 5 as one solid grey band (thousands of places
    in a 600 px frame). The picture shows the most levels that leave every place MIN_PLACE pixels, and says so."""
    path = os.path.join(ROOT, "addon", "raylab", "meshes", "armadillo.obj")
    tree = tree_view.Tree(("armadillo",), raylab.build_file(path, structure="bvh"))
    width = 600
    assert tree.picture(0, 5)["places"] * tree_view.MIN_PLACE > width  # what was drawn: a band
    fit = tree.fitting_levels(0, 5, width)
    assert 1 <= fit < 5 and tree.picture(0, fit)["places"] * tree_view.MIN_PLACE <= width
    assert tree.picture(0, fit + 1)["places"] * tree_view.MIN_PLACE > width  # the most that fit
    assert tree.fitting_levels(0, 2, width) == 2  # levels that fit are kept


def test_the_left_button_s_name_in_the_status_bar_says_where_it_picks():
    """Issue 42 item 5: the status bar read "Pick a Node" for the left button over the whole viewport, where a
    click outside the tree view selects as usual: the name says it picks in the tree view."""
    assert tree_view.RAYLAB_OT_tree_click.bl_label == "Pick a Node in the Tree View"
