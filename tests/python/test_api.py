"""The Python API as a user meets it: results, counters, the single-ray story, boxes, and the clear
errors that bad input must raise instead of crashing the interpreter."""
import gc
import math
import subprocess
import sys
import threading

import numpy as np
import pytest

import raylab
from raylab import rays
from conftest import ADDON, MESH_DIR, load

STRUCTURES = raylab.STRUCTURES


def test_the_core_vocabularies_are_exported_once_and_complete():
    # VRT's three and the BVH come first, brute force first of all (the reference everything is held to).
    assert STRUCTURES[:4] == ("none", "aabb", "octree", "bvh")
    assert len(set(STRUCTURES)) == len(STRUCTURES)
    for name, info in raylab.STRUCTURE_INFO.items():
        assert info["label"] and info["description"] and info["root_name"], name
        assert raylab.build(*load("sphere"), structure=name).structure == name
    assert raylab.TRIANGLE_TESTS == ("watertight", "moller_trumbore")
    assert all(info["label"] and info["description"] for info in raylab.TRIANGLE_TEST_INFO.values())
    # Every stats dict has exactly the exported counters, in order.
    stats = raylab.build(*load("sphere")).intersect([0, 0, 5], [0, 0, -1], count=True).stats
    assert tuple(stats) == raylab.COUNTERS
    assert raylab.COUNTERS[:2] == ("rays", "rays_ignored")
    # The defaults are the core's, and the Python signatures show them.
    import inspect
    assert raylab.DEFAULTS["structure"] == "bvh" and raylab.DEFAULTS["max_depth_limit"] == 16
    for function in (raylab.build, raylab.build_file, raylab.Scene, raylab.Scene.set_settings):
        parameters = inspect.signature(function).parameters
        for name in ("structure", "max_depth", "leaf_size", "triangle_test"):
            assert parameters[name].default == raylab.DEFAULTS[name], (function, name)
    assert issubclass(raylab.BuildError, RuntimeError)


def test_load_mesh_gives_float32_vertices_and_uint32_triangles(sphere):
    vertices, triangles = sphere
    assert vertices.dtype == np.float32 and vertices.shape == (642, 3)
    assert triangles.dtype == np.uint32 and triangles.shape == (1280, 3)
    assert triangles.max() < len(vertices)


def test_load_mesh_of_a_missing_file_raises_oserror_naming_it(tmp_path):
    missing = tmp_path / "no_such_mesh.obj"
    with pytest.raises(OSError, match="no_such_mesh.obj"):
        raylab.load_mesh(missing)
    with pytest.raises(OSError, match="no_such_mesh.obj"):
        raylab.build_file(missing, structure="aabb")


def test_build_file_equals_build_of_the_loaded_mesh(sphere):
    from_file = raylab.build_file(MESH_DIR / "sphere.obj", structure="aabb")
    assert from_file.triangle_count == 1280 and from_file.vertex_count == 642
    o, d = rays.camera_rays(sphere[0], 16)
    expected = raylab.build(*sphere, structure="aabb").intersect(o, d)
    assert np.array_equal(from_file.intersect(o, d).triangle, expected.triangle)


@pytest.mark.parametrize("structure", STRUCTURES)
def test_structure_properties(sphere, structure):
    s = raylab.build(*sphere, structure=structure, max_depth=4, leaf_size=3)
    assert s.structure == structure
    assert (s.triangle_count, s.vertex_count) == (1280, 642)
    assert s.build_seconds >= 0.0
    assert isinstance(s.memory_bytes, int)
    if raylab.STRUCTURE_INFO[structure]["uses_top_level"]:  # the hierarchies
        assert s.memory_bytes > 0
    assert (s.max_depth, s.leaf_size, s.triangle_test) == (4, 3, "watertight")


def test_octree_max_depth_is_auto_by_default_or_a_whole_number(sphere):
    assert raylab.DEFAULTS["max_depth"] == "auto"
    assert raylab.build(*sphere, structure="octree").max_depth == "auto"
    assert raylab.build(*sphere, structure="octree", max_depth="auto").max_depth == "auto"
    # auto caps the depth at log4(1280 triangles / 8 per leaf), rounded up, plus 2: 6.
    auto = raylab.build(*sphere, structure="octree").boxes()
    assert 3 <= auto["depth"].max() <= 6
    fixed = raylab.build(*sphere, structure="octree", max_depth=2)
    assert fixed.max_depth == 2 and fixed.boxes()["depth"].max() == 2
    o, d = rays.camera_rays(sphere[0], 24)
    expected = raylab.build(*sphere, structure="none").intersect(o, d)
    got = raylab.build(*sphere, structure="octree").intersect(o, d)
    assert np.array_equal(expected.triangle, got.triangle) and np.array_equal(expected.t, got.t)


@pytest.mark.parametrize("structure", STRUCTURES)
def test_intersect_results_have_the_agreed_shapes_and_dtypes(sphere, structure):
    s = raylab.build(*sphere, structure=structure)
    origins = np.array([[0, 0, -5], [0, 0, -5], [3, 3, 3]], np.float32)
    directions = np.array([[0, 0, 1], [0, 1, 0], [-1, -1, -1]], np.float32)
    h = s.intersect(origins, directions)
    assert len(h) == 3
    for name, dtype in [("t", np.float32), ("u", np.float32), ("v", np.float32), ("triangle", np.int32),
                        ("instance", np.int32), ("hit", np.bool_)]:
        a = getattr(h, name)
        assert a.dtype == dtype and a.shape == (3,), name
    assert h.stats is None
    assert list(h.hit) == [True, False, True]
    assert h.t[0] == pytest.approx(4.0, rel=1e-3)
    assert h.t[2] == pytest.approx((math.sqrt(27) - 1) / math.sqrt(3), rel=1e-2)
    assert (h.t[1], h.triangle[1], h.instance[1]) == (np.inf, -1, -1)
    assert list(h.instance) == [0, -1, 0]
    o = s.occluded(origins, directions)
    assert o.hit.dtype == np.bool_ and list(o.hit) == [True, False, True] and o.stats is None


@pytest.mark.parametrize("structure", STRUCTURES)
def test_hit_points_lie_on_their_triangles(sphere, structure):
    vertices, triangles = sphere
    o, d = rays.camera_rays(vertices, 48)
    h = raylab.build(vertices, triangles, structure=structure).intersect(o, d)
    assert h.hit.sum() > 300
    p = vertices[triangles[h.triangle[h.hit]]].astype(np.float64)
    u, v = h.u[h.hit, None].astype(np.float64), h.v[h.hit, None].astype(np.float64)
    on_triangle = (1 - u - v) * p[:, 0] + u * p[:, 1] + v * p[:, 2]
    along_ray = o[h.hit] + h.t[h.hit, None].astype(np.float64) * d[h.hit]
    assert np.abs(on_triangle - along_ray).max() < 1e-5
    assert (u >= 0).all() and (v >= 0).all() and (u + v <= 1 + 1e-6).all()


def moller_trumbore_float64(vertices, triangles, origins, directions):
    """An independent oracle: the closest t of every ray over all triangles, in float64 numpy, and the
    smallest barycentric coordinate of that hit (how close it lies to an edge)."""
    p = vertices[triangles].astype(np.float64)
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    best_t = np.full(len(origins), np.inf)
    margin = np.zeros(len(origins))
    for i, (o, d) in enumerate(zip(origins.astype(np.float64), directions.astype(np.float64))):
        q = np.cross(d, e2)
        det = (e1 * q).sum(1)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = o - p[:, 0]
            u = (s * q).sum(1) / det
            r = np.cross(s, e1)
            v = (r * d).sum(1) / det
            t = (r * e2).sum(1) / det
        ok = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        if ok.any():
            j = np.flatnonzero(ok)[np.argmin(t[ok])]
            best_t[i] = t[j]
            margin[i] = min(u[j], v[j], 1 - u[j] - v[j])
    return best_t, margin


@pytest.mark.parametrize("structure", STRUCTURES)
def test_closest_hits_match_an_independent_float64_oracle(sphere, structure):
    vertices, triangles = sphere
    o, d = rays.random_rays(vertices, 400, np.random.default_rng(7))
    expected_t, margin = moller_trumbore_float64(vertices, triangles, o, d)
    h = raylab.build(vertices, triangles, structure=structure).intersect(o, d)
    clear = (margin > 1e-4) | ~np.isfinite(expected_t)  # away from edges, where rounding may decide
    assert clear.sum() > 350
    assert np.array_equal(h.hit[clear], np.isfinite(expected_t[clear]))
    assert np.allclose(h.t[clear & h.hit], expected_t[clear & h.hit], rtol=1e-5)


@pytest.mark.parametrize("structure", STRUCTURES)
def test_tmin_and_tmax_bound_the_search(sphere, structure):
    s = raylab.build(*sphere, structure=structure)
    origin, direction = np.array([0, 0, -5.0]), np.array([0, 0, 1.0])
    near = s.intersect(origin, direction).t[0]
    assert near == pytest.approx(4.0, rel=1e-3)
    assert not s.intersect(origin, direction, tmax=3.9).hit[0]
    assert s.intersect(origin, direction, tmin=near + 0.1).t[0] == pytest.approx(6.0, rel=1e-3)
    assert not s.occluded(origin, direction, tmax=3.9).hit[0]
    assert s.occluded(origin, direction, tmin=4.5, tmax=7.0).hit[0]


@pytest.mark.parametrize("structure", STRUCTURES)
def test_one_origin_or_direction_row_is_shared_by_all_rays(sphere, structure):
    s = raylab.build(*sphere, structure=structure)
    directions = np.array([[0, 0, 1], [0, 1, 0], [0.1, 0, 1]], np.float32)
    shared = s.intersect([0, 0, -5], directions)
    full = s.intersect(np.tile([0, 0, -5], (3, 1)), directions)
    assert np.array_equal(shared.triangle, full.triangle) and np.array_equal(shared.t, full.t)
    parallel = s.intersect([[0, 0, -5], [0.5, 0, -5], [5, 5, -5]], [0, 0, 1])
    assert list(parallel.hit) == [True, True, False]


def test_other_real_dtypes_are_converted(sphere):
    vertices, triangles = sphere
    o, d = rays.camera_rays(vertices, 16)
    expected = raylab.build(vertices, triangles, "none").intersect(o, d)
    for v, t in [(vertices.astype(np.float64), triangles.astype(np.int64)),
                 (vertices, triangles.astype(np.int32)), (vertices, triangles.astype(np.uint64)),
                 (vertices.tolist(), triangles.tolist())]:
        h = raylab.build(v, t, "none").intersect(o.astype(np.float64), d.tolist())
        assert np.array_equal(h.triangle, expected.triangle)


def test_non_contiguous_arrays_are_read_correctly(sphere):
    vertices, triangles = sphere
    wide = np.zeros((len(vertices), 6), np.float32)
    wide[:, ::2] = vertices
    o, d = rays.camera_rays(vertices, 16)
    expected = raylab.build(vertices, triangles, "none").intersect(o, d)
    h = raylab.build(wide[:, ::2], np.asfortranarray(triangles), "none").intersect(o[::-1][::-1], d)
    assert np.array_equal(h.triangle, expected.triangle)


# (keyword overrides of build, expected message fragment): each must raise ValueError naming the problem.
TRIANGLE = (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2], [2, 1, 0]], np.uint32))
BAD_BUILDS = {
    "vertex shape": (dict(vertices=np.zeros((3, 2), np.float32)), "vertices must have shape (N, 3)"),
    "vertex rank": (dict(vertices=np.zeros(9, np.float32)), "vertices must have shape (N, 3)"),
    "triangle shape": (dict(triangles=np.zeros((2, 4), np.uint32)), "triangles must have shape (T, 3)"),
    "float triangles": (dict(triangles=np.array([[0, 1, 2.0]])), "triangles must have an integer dtype"),
    "complex vertices": (dict(vertices=TRIANGLE[0].astype(np.complex64)), "vertices must have a real number dtype"),
    "string vertices": (dict(vertices=np.array([["a", "b", "c"]] * 3)), "vertices must have a real number dtype"),
    "no vertices": (dict(vertices=None), "vertices must be an array"),
    "negative index": (dict(triangles=np.array([[0, 1, 2], [0, -1, 2]])), "triangle 1 has a negative vertex index -1"),
    "index out of range": (dict(triangles=np.array([[0, 1, 2], [0, 1, 99]], np.uint32)),
                           "triangle 1 refers to vertex 99 but the mesh has 3 vertices"),
    "huge index": (dict(triangles=np.array([[0, 1, 2], [0, 1, 2 ** 40]], np.uint64)), "triangle 1 refers to vertex"),
    "NaN vertex": (dict(vertices=np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], np.float32)),
                   "vertex 2 has a NaN or infinite coordinate"),
    "infinite vertex": (dict(vertices=np.array([[0, 0, 0], [np.inf, 0, 0], [0, 1, 0]])),
                        "vertex 1 has a NaN or infinite coordinate"),
    "negative depth": (dict(max_depth=-1), "max_depth must be >= 0"),
    "leaf size": (dict(leaf_size=0), "leaf_size must be >= 1"),
    "unknown structure": (dict(structure="kdtree"), "unknown structure 'kdtree'"),
    "unknown triangle test": (dict(triangle_test="plucker"), "unknown triangle_test 'plucker'"),
    "zero budget": (dict(memory_budget=0), "memory_budget must be positive"),
    "negative budget": (dict(memory_budget=-5), "memory_budget must be positive"),
    "fractional budget": (dict(memory_budget=1.5), "memory_budget must be a whole number"),
}


@pytest.mark.parametrize("case", BAD_BUILDS, ids=list(BAD_BUILDS))
@pytest.mark.parametrize("structure", STRUCTURES)
def test_bad_build_input_raises_a_value_error_naming_it(case, structure):
    overrides, message = BAD_BUILDS[case]
    arguments = dict(vertices=TRIANGLE[0], triangles=TRIANGLE[1], structure=structure)
    arguments.update(overrides)
    with pytest.raises(ValueError) as error:
        raylab.build(**arguments)
    assert message in str(error.value)


GOOD_RAY = (np.array([[0.2, 0.2, 1.0]] * 3, np.float32), np.array([[0, 0, -1.0]] * 3, np.float32))
BAD_RAYS = {
    "origin shape": (dict(origins=np.zeros((3, 2))), "origins must have shape (N, 3) or (3,)"),
    "direction shape": (dict(directions=np.zeros((3, 3, 1))), "directions must have shape (N, 3) or (3,)"),
    "lengths differ": (dict(directions=np.ones((2, 3))), "origins and directions differ in length: 3 and 2"),
    "NaN origin": (dict(origins=np.array([[0, 0, 1], [0, np.nan, 1], [0, 0, 1]])),
                   "origin of ray 1 has a NaN or infinite coordinate"),
    "infinite direction": (dict(directions=np.array([[0, 0, -1], [0, 0, -1], [0, -np.inf, -1]])),
                           "direction of ray 2 has a NaN or infinite coordinate"),
    "zero direction": (dict(directions=np.array([[0, 0, -1], [0, 0, 0], [0, 0, -1]])),
                       "direction of ray 1 has zero length"),
    "bool origins": (dict(origins=np.ones((3, 3), bool)), "origins must have a real number dtype"),
    "tmin above tmax": (dict(tmin=2.0, tmax=1.0), "tmin (2.000000) is greater than tmax (1.000000)"),
    "NaN tmin": (dict(tmin=float("nan")), "tmin and tmax must not be NaN"),
}


@pytest.mark.parametrize("case", BAD_RAYS, ids=list(BAD_RAYS))
@pytest.mark.parametrize("query", ["intersect", "occluded"])
@pytest.mark.parametrize("structure", STRUCTURES)
def test_bad_rays_raise_a_value_error_naming_them(case, query, structure):
    s = raylab.build(*TRIANGLE, structure=structure)
    overrides, message = BAD_RAYS[case]
    arguments = dict(origins=GOOD_RAY[0], directions=GOOD_RAY[1])
    arguments.update(overrides)
    with pytest.raises(ValueError) as error:
        getattr(s, query)(**arguments)
    assert message in str(error.value)


@pytest.mark.parametrize("structure", STRUCTURES)
def test_bad_story_rays_raise_value_errors(structure):
    s = raylab.build(*TRIANGLE, structure=structure)
    with pytest.raises(ValueError, match="shape"):
        s.story(GOOD_RAY[0], GOOD_RAY[1])
    with pytest.raises(ValueError, match="zero length"):
        s.story([0, 0, 1], [0, 0, 0])
    with pytest.raises(ValueError, match="NaN or infinite"):
        s.story([0, np.nan, 1], [0, 0, -1])
    with pytest.raises(ValueError, match="greater than tmax"):
        s.story([0, 0, 1], [0, 0, -1], tmin=3, tmax=2)


def test_an_octree_too_deep_for_the_memory_budget_is_refused_before_it_is_built():
    # In a fresh process, so that its peak memory is the build's own: the 4 GiB default budget is
    # refused from an estimate, without first holding gigabytes (it used to stop at 2 GB).
    script = ("import resource, sys; sys.path.insert(0, sys.argv[1]); import raylab\n"
              "v, t = raylab.load_mesh(sys.argv[2])\n"
              "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
              "try:\n    raylab.build(v, t, structure='octree', max_depth=16, leaf_size=1)\n"
              "except raylab.BuildError as e:\n    print(e)\n"
              "print((resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) // 1024)\n")
    out = subprocess.run([sys.executable, "-c", script, str(ADDON), str(MESH_DIR / "dragon.obj")],
                         capture_output=True, text=True, check=True).stdout.splitlines()
    assert "memory budget" in out[0] and "estimated before building" in out[0], out
    assert int(out[1]) < 512, f"the refused build grew the process by {out[1]} MB"


def test_the_memory_estimate_refuses_only_what_the_build_would_refuse():
    # bunny.obj at depth 11, leaf_size 1: the build's own checks need 194 MB (measured with the
    # estimate switched off; with it on, the smallest budget that builds is the same on bunny, dragon,
    # armadillo and goathead). A budget 3% above builds; one far below is refused before building.
    bunny = load("bunny")
    s = raylab.build(*bunny, structure="octree", max_depth=11, leaf_size=1, memory_budget=200 << 20)
    assert s.memory_bytes > 0
    with pytest.raises(raylab.BuildError, match="estimated before building"):
        raylab.build(*bunny, structure="octree", max_depth=11, leaf_size=1, memory_budget=120 << 20)


@pytest.mark.parametrize("structure", ["octree", "bvh"])
def test_a_small_memory_budget_raises_build_error(structure):
    with pytest.raises(raylab.BuildError):
        raylab.build(*load("bunny"), structure=structure, memory_budget=1024)


@pytest.mark.parametrize("structure", STRUCTURES)
def test_an_empty_mesh_is_missed_by_every_ray(structure):
    s = raylab.build(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint32), structure=structure)
    assert s.triangle_count == 0
    o, d = rays.random_rays(np.array([[-1, -1, -1], [1, 1, 1]], np.float32), 100, np.random.default_rng(1))
    h = s.intersect(o, d, count=True)
    assert not h.hit.any() and (h.triangle == -1).all() and np.isinf(h.t).all()
    assert h.stats["rays"] == 100 and h.stats["triangle_tests"] == 0
    assert not s.occluded(o, d).hit.any()
    story = s.story(o[0], d[0])
    assert story.hit is None and story.status != "hit_object"
    boxes = s.boxes()
    if structure in ("none", "aabb"):  # VRT's models: no boxes without triangles
        assert len(boxes["depth"]) == 0


def box_rays(vertices, n, rng):
    """Rays from far outside: the first half aimed at points well inside the bounding box (they enter
    it), the second half pointing away from the box (they miss it and the octree's root cube)."""
    lo, hi = rays.bounds(vertices)
    centre = (lo + hi) / 2
    origins = rays.outside_points(vertices, n, rng)
    inside = rng.uniform(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), (n, 3))
    directions = inside - origins
    away = origins - centre
    directions[n // 2:] = away[n // 2:] + 0.2 * np.linalg.norm(away[n // 2:], axis=1, keepdims=True) * \
        rays.random_directions(rng, n - n // 2)
    return origins.astype(np.float32), directions.astype(np.float32), n - n // 2


@pytest.mark.parametrize("structure", STRUCTURES)
@pytest.mark.parametrize("query", ["intersect", "occluded"])
def test_counters_count_rays_ignored_and_tests(structure, query):
    vertices, triangles = load("bunny")
    o, d, missing = box_rays(vertices, 2000, np.random.default_rng(3))
    stats = getattr(raylab.build(vertices, triangles, structure=structure), query)(o, d, count=True).stats
    assert set(stats) == set(raylab.COUNTERS)  # the vocabulary, whatever counters it holds
    assert {"rays", "rays_ignored", "box_tests", "triangle_tests", "nodes_visited"} <= set(stats)
    assert stats["rays"] == 2000
    if structure == "none":
        assert stats["rays_ignored"] == 0 and stats["box_tests"] == 0
        if query == "intersect":
            assert stats["triangle_tests"] == 2000 * len(triangles)
    else:
        assert stats["rays_ignored"] == missing
        assert stats["box_tests"] >= 2000
        assert 0 < stats["triangle_tests"] <= (2000 - missing) * len(triangles)
    if structure == "aabb" and query == "intersect":
        assert stats["triangle_tests"] == (2000 - missing) * len(triangles)
    if structure in ("octree", "bvh"):
        # The point of a hierarchy: far fewer triangle tests than the box alone.
        assert stats["triangle_tests"] < 0.1 * (2000 - missing) * len(triangles)


@pytest.mark.parametrize("structure", STRUCTURES)
def test_story_of_a_hit_tells_what_the_counters_count(sphere, structure):
    s = raylab.build(*sphere, structure=structure, max_depth=3, leaf_size=4)
    origin, direction = np.array([0.1, 0.2, -5.0]), np.array([0, 0, 1.0])
    st = s.story(origin, direction)
    h = s.intersect(origin, direction, count=True)
    assert st.status == "hit_object"
    assert st.hit["triangle"] == h.triangle[0] and st.hit["t"] == h.t[0]
    assert np.allclose(st.hit["point"], origin + h.t[0] * direction, atol=1e-5)
    assert st.stats == h.stats
    assert len(st.triangles) == st.stats["triangle_tests"] and st.triangles.dtype == np.int32
    assert st.triangle_hits[list(st.triangles).index(h.triangle[0])]
    assert len(st.nodes) == len(st.node_depths) == st.stats["nodes_visited"]
    assert st.nodes.dtype == np.int32 and st.node_depths.dtype == np.int32
    boxes = st.boxes
    assert set(boxes) == {"lo", "hi", "depth", "hit", "t_entry", "node"}
    assert boxes["lo"].shape == (st.stats["box_tests"], 3)
    entered = boxes["hit"]
    assert np.isfinite(boxes["t_entry"][entered]).all() and np.isinf(boxes["t_entry"][~entered]).all()
    assert set(st.nodes) <= set(boxes["node"][entered]), "a node was visited without its box being hit"


@pytest.mark.parametrize("structure", ["aabb", "octree", "bvh"])
def test_story_of_a_ray_missing_the_object_says_where_it_failed(sphere, structure):
    s = raylab.build(*sphere, structure=structure, max_depth=3, leaf_size=4)
    away = s.story([0, 0, -5], [0, 0, -1])
    assert away.status == "missed_root" and away.hit is None and len(away.triangles) == 0
    assert away.stats["rays_ignored"] == 1
    # Through the corner of the bounding box, beside the sphere: enters the box, misses the sphere.
    corner = s.story([-5, 0.95, 0.95], [1, 0, 0])
    assert corner.status in ("missed_nodes", "missed_triangles") and corner.hit is None
    assert corner.boxes["hit"][0]
    if structure == "aabb":
        assert corner.status == "missed_triangles" and len(corner.triangles) == 1280


@pytest.mark.parametrize("structure", STRUCTURES)
def test_boxes_cover_the_mesh(sphere, structure):
    vertices, triangles = sphere
    b = raylab.build(vertices, triangles, structure=structure, max_depth=3, leaf_size=8).boxes()
    n = len(b["depth"])
    assert b["lo"].shape == (n, 3) and b["hi"].shape == (n, 3) and b["lo"].dtype == np.float32
    assert b["depth"].dtype == np.int32 and b["leaf"].dtype == np.bool_ and b["triangle_count"].dtype == np.uint32
    if structure == "none":
        assert n == 0
        return
    assert (b["lo"] <= b["hi"]).all() and (b["depth"] >= 0).all()
    root = np.flatnonzero(b["depth"] == 0)
    assert len(root) == 1
    lo, hi = vertices.min(0), vertices.max(0)
    assert (b["lo"][root[0]] <= lo).all() and (b["hi"][root[0]] >= hi).all()
    assert b["triangle_count"][root[0]] >= len(triangles)
    leaves = b["leaf"]
    assert leaves.any() and b["triangle_count"][leaves].sum() >= len(triangles)
    if structure == "octree":
        extent = b["hi"][root[0]] - b["lo"][root[0]]
        assert np.allclose(extent, extent[0])  # the root is a cube
        assert b["depth"].max() <= 3


def test_a_structure_keeps_its_mesh_after_the_arrays_are_gone():
    vertices, triangles = (a.copy() for a in load("sphere"))
    s = raylab.build(vertices, triangles, structure="bvh")
    o, d = rays.camera_rays(vertices, 16)
    expected = s.intersect(o, d).triangle
    del vertices, triangles
    gc.collect()
    assert np.array_equal(s.intersect(o, d).triangle, expected)
    v, t = s.mesh()
    assert v.shape == (642, 3) and t.shape == (1280, 3)


def test_intersect_releases_the_gil():
    """A Python thread keeps running while native code traces: with a huge switch interval the other
    thread can only run if intersect lets go of the GIL."""
    vertices, triangles = load("bunny")
    s = raylab.build(vertices, triangles, structure="none")
    o, d = rays.random_rays(vertices, 20_000, np.random.default_rng(5))
    ticks, stop = [0], threading.Event()

    def tick():
        while not stop.is_set():
            ticks[0] += 1
            stop.wait(0.0005)  # waiting releases the GIL so that the main thread can take it back

    worker = threading.Thread(target=tick)
    interval = sys.getswitchinterval()
    worker.start()
    try:
        while ticks[0] == 0:
            stop.wait(0.001)
        sys.setswitchinterval(100.0)
        before = ticks[0]
        s.intersect(o, d)
        during = ticks[0] - before
    finally:
        sys.setswitchinterval(interval)
        stop.set()
        worker.join()
    assert during > 0


@pytest.mark.parametrize("structure", STRUCTURES)
def test_batch_statuses_say_what_each_rays_story_says(sphere, structure):
    s = raylab.build(*sphere, structure=structure, max_depth=4, leaf_size=3)
    rng = np.random.default_rng(11)
    origins = rng.uniform(-3, 3, (400, 3)).astype(np.float32)
    directions = rng.normal(size=(400, 3)).astype(np.float32)
    batch = s.statuses(origins, directions)
    hits = s.intersect(origins, directions)
    assert np.array_equal(batch.t, hits.t) and np.array_equal(batch.triangle, hits.triangle)
    stories = [s.story(o, d) for o, d in zip(origins, directions)]
    assert [raylab.RAY_STATUSES[k] for k in batch.status] == [st.status for st in stories]
    seen = {raylab.RAY_STATUSES[k] for k in batch.status}
    assert "hit_object" in seen and ("missed_root" in seen or structure == "none")


@pytest.mark.parametrize("structure", STRUCTURES)
def test_answers_and_counters_are_the_same_on_any_number_of_threads(structure):
    """threads= changes who traces, never what: hits, occlusion, statuses and the summed counters of
    threads=1, threads=2 and the default (all cores) agree bit for bit, for a Structure and a Scene."""
    vertices, triangles = load("bunny")
    o, d, _ = box_rays(vertices, 3000, np.random.default_rng(5))
    s = raylab.build(vertices, triangles, structure=structure)
    scene = raylab.Scene(structure=structure)
    scene.add_instance(scene.add_mesh(vertices, triangles), np.eye(4))
    scene.commit()
    for target in (s, scene):
        closest = [target.intersect(o, d, count=True, threads=n) for n in (1, 2, None, 0)]
        anyhit = [target.occluded(o, d, count=True, threads=n) for n in (1, 2, None, np.int64(2))]
        for h in closest[1:]:
            for field in ("t", "triangle", "u", "v", "instance", "hit"):
                assert np.array_equal(getattr(h, field), getattr(closest[0], field))
            assert h.stats == closest[0].stats
        for a in anyhit[1:]:
            assert np.array_equal(a.hit, anyhit[0].hit) and a.stats == anyhit[0].stats
        assert closest[0].hit.any() and not closest[0].hit.all()
    one, two = s.statuses(o, d, threads=1), s.statuses(o, d, threads=2)
    assert np.array_equal(one.status, two.status) and np.array_equal(one.t, two.t)
