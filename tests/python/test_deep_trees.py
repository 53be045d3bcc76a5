"""Trees as deep as the builders make them: collinear, sorted and tiny triangles, whose boxes tie (zero
area) and let the wide BVH open one side of the tree only. Every walk (closest and any hit, counted,
per ray, stories, the Scene's, a refit) must hold the deepest path's entries and give brute force's
answer. A crash is observed in a child process, so that it fails the test instead of ending pytest."""
import os
import subprocess
import sys

import numpy as np
import pytest

import raylab
from conftest import ADDON, load

CHILD_PRELUDE = """
import numpy as np, raylab

def collinear(n=9000):
    x = np.sort(np.random.default_rng(0).uniform(0, 1, n)).astype(np.float32)
    vertices = np.zeros((n, 3), np.float32)
    vertices[:, 0] = x
    return vertices, np.arange(n, dtype=np.uint32).reshape(-1, 3)

def bunny(scale):
    vertices, triangles = raylab.load_mesh(%r)
    return (vertices * scale).astype(np.float32), triangles
""" % str(ADDON / "raylab" / "meshes" / "bunny.obj")

# Each query through every path that walks the BVH; each was a segmentation fault (a traversal stack of
# 256 entries; the collinear soup's deepest path needs 315, the bunny scaled by 1e-30 301).
QUERIES = {
    "occluded": "raylab.build(*collinear(), builder=B).occluded(np.float32([[-1, 0, 0]]), np.float32([[1, 0, 0]]))",
    "intersect": "raylab.build(*bunny(1e-30), builder=B).intersect(np.float32([[0, 0, 1]]), "
                 "np.float32([[0, 0, -1]]))",
    "counted": "raylab.build(*collinear(), builder=B).intersect(np.float32([[-1, 0, 0]]), np.float32([[1, 0, 0]]), "
               "count=True, per_ray=True)",
    "story": "raylab.build(*bunny(1e-30), builder=B).story(np.float32([0, 0, 1]), np.float32([0, 0, -1]))",
    "scene": "s = raylab.Scene(builder=B); s.add_instance(s.add_mesh(*collinear()), np.eye(4)); s.commit(); "
             "s.occluded(np.float32([[-1, 0, 0]]), np.float32([[1, 0, 0]]), count=True)",
    "refit to zeros": "v, t = bunny(1e-30); st = raylab.build(v, t, builder=B).refit(np.zeros_like(v)); "
                      "st.intersect(np.float32([[0, 0, 1]]), np.float32([[0, 0, -1]]))",
}


@pytest.mark.parametrize("builder", raylab.BUILDERS)
@pytest.mark.parametrize("query", QUERIES)
def test_the_deepest_trees_are_walked_without_a_crash(query, builder):
    code = CHILD_PRELUDE + f"B = {builder!r}\n" + QUERIES[query] + "\nprint('done')\n"
    child = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                           env={**os.environ, "PYTHONPATH": str(ADDON)})
    assert child.returncode == 0 and child.stdout.strip() == "done", (child.returncode, child.stderr[-2000:])


def collinear(n):
    x = np.sort(np.random.default_rng(1).uniform(0, 1, n)).astype(np.float32)
    vertices = np.zeros((n, 3), np.float32)
    vertices[:, 0] = x
    vertices[:, 1] = np.float32(1e-6) * (np.arange(n) % 3 == 1)  # thin slivers along x, hit from +z
    return vertices, np.arange(n, dtype=np.uint32).reshape(-1, 3)


def deepest_path_entries(tree):
    """The most children pushed along one root-to-leaf path of the wide tree: what a walk holds."""
    children, inner = tree["children"], tree["children"].shape[0]
    most, todo = 0, [(0, 0)]
    while todo:
        node, held = todo.pop()
        if node >= inner:
            continue
        kids = children[node][children[node] >= 0]
        most = max(most, held + len(kids))
        todo.extend((int(k), held + len(kids)) for k in kids)
    return most


@pytest.mark.parametrize("scale", [1.0, 1e-30, 1e18])
def test_deep_trees_give_brute_forces_hits(scale):
    vertices, triangles = collinear(9000)
    vertices = (vertices * np.float32(scale)).astype(np.float32)
    rng = np.random.default_rng(2)
    x = rng.uniform(-0.1, 1.1, 2000).astype(np.float32) * np.float32(scale)
    origins = np.stack([x, np.full_like(x, 3e-7 * scale), np.full_like(x, scale)], axis=1)
    directions = np.float32([0, 0, -1])
    reference = raylab.build(vertices, triangles, structure="none")
    expected = reference.intersect(origins, directions)
    for builder in raylab.BUILDERS:
        structure = raylab.build(vertices, triangles, builder=builder)
        hits = structure.intersect(origins, directions)
        np.testing.assert_array_equal(hits.triangle, expected.triangle, err_msg=builder)
        np.testing.assert_array_equal(hits.t, expected.t, err_msg=builder)
        np.testing.assert_array_equal(structure.occluded(origins, directions).hit, expected.hit, err_msg=builder)


@pytest.mark.parametrize("scale", [1e-30, 1e-25])
def test_a_shipped_mesh_scaled_down_keeps_brute_forces_hits(scale):
    vertices, triangles = load("bunny")
    tiny = (vertices * np.float32(scale)).astype(np.float32)
    origins, directions = raylab.rays.camera_rays(tiny, 48)
    expected = raylab.build(tiny, triangles, structure="none").intersect(origins, directions)
    assert expected.hit.any()
    if scale == 1e-30:  # the case the stack of 256 entries missed
        assert deepest_path_entries(raylab.build(tiny, triangles).tree()) > 256
    for builder in raylab.BUILDERS:
        got = raylab.build(tiny, triangles, builder=builder).intersect(origins, directions)
        np.testing.assert_array_equal(got.triangle, expected.triangle, err_msg=builder)
