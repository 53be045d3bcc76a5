"""The exactness contract on the floating-point edge cases of issue 10: every structure returns brute
force's closest hit (same triangle, same t, bit for bit) and the same occlusion answer, no hit is
ever reported at an infinite or NaN t or at t <= tmin, and coordinates too large for the float tests
are refused at build. See README "Exactness and its limits"."""
import math

import numpy as np
import pytest

import raylab
from conftest import load

STRUCTURES = raylab.STRUCTURES


def quad(z=0.0, scale=1.0):
    vertices = np.array([[0, 0, z], [1, 0, z], [1, 1, z], [0, 1, z]], np.float32) * np.float32(scale)
    return vertices, np.array([[0, 1, 2], [0, 2, 3]], np.uint32)


def assert_all_equal_brute_force(vertices, triangles, origins, directions, what, **kwargs):
    """Closest hits bit-identical to `none`, occlusion identical, for every structure."""
    structures = {s: raylab.build(vertices, triangles, s, **kwargs) for s in STRUCTURES}
    reference = structures["none"].intersect(origins, directions)
    occluded = structures["none"].occluded(origins, directions).hit
    for name, s in structures.items():
        got = s.intersect(origins, directions)
        bad = (got.hit != reference.hit) | (got.triangle != reference.triangle) | \
              ~((got.t == reference.t) | (~got.hit & ~reference.hit))
        assert not bad.any(), (f"{what}: {name} differs from none on {int(bad.sum())} of {len(bad)} rays; first "
                               f"{np.flatnonzero(bad)[0]}")
        assert np.array_equal(s.occluded(origins, directions).hit, occluded), f"{what}: {name} occlusion differs"
    return reference


def test_origins_just_above_a_flat_mesh_give_the_brute_force_hit():
    # Finding 2: a sphere flattened to z = 0, rays starting 1e-7 above it in every direction.
    vertices, triangles = load("sphere")
    flat = vertices.copy()
    flat[:, 2] = 0.0
    rng = np.random.default_rng(2)
    n = 20_000
    radius = np.sqrt(rng.uniform(0, 1, n)) * 0.9 * np.abs(flat[:, 0]).max()
    angle = rng.uniform(0, 2 * np.pi, n)
    origins = np.stack([radius * np.cos(angle), radius * np.sin(angle), np.full(n, 1e-7)], 1).astype(np.float32)
    directions = rng.normal(size=(n, 3)).astype(np.float32)
    reference = assert_all_equal_brute_force(flat, triangles, origins, directions, "1e-7 above a flat sphere")
    down = directions[:, 2] < 0
    assert reference.hit[down].mean() > 0.9  # the downward rays really hit the flat mesh


@pytest.mark.parametrize("query", ["intersect", "occluded"])
def test_tmax_just_past_a_hit_still_sees_it(query):
    # Finding 3: shadow rays whose tmax lies a hair past the surface they end on.
    vertices, triangles = quad()
    rng = np.random.default_rng(3)
    origins = np.column_stack([rng.uniform(-1, 2, 400), rng.uniform(-1, 2, 400), rng.uniform(0.1, 3, 400)])
    targets = np.column_stack([rng.uniform(0, 1, 400), rng.uniform(0, 1, 400), np.zeros(400)])
    origins, directions = origins.astype(np.float32), (targets - origins).astype(np.float32)
    structures = {s: raylab.build(vertices, triangles, s) for s in STRUCTURES}
    reference = structures["none"].intersect(origins, directions)
    assert reference.hit.all()
    missed = {s: 0 for s in STRUCTURES}
    for i in range(len(origins)):
        tmax = float(reference.t[i]) * 1.000001
        for name, s in structures.items():
            if query == "intersect":
                h = s.intersect(origins[i], directions[i], tmax=tmax)
                missed[name] += not (h.hit[0] and h.t[0] == reference.t[i] and h.triangle[0] == reference.triangle[i])
            else:
                missed[name] += not s.occluded(origins[i], directions[i], tmax=tmax).hit[0]
    assert missed == {s: 0 for s in STRUCTURES}


def test_negative_tmin_has_one_meaning_everywhere():
    # Finding 4: whatever the argument parsing lets through, all structures agree on it.
    vertices, triangles = quad()
    answers = []
    for s in STRUCTURES:
        structure = raylab.build(vertices, triangles, s)
        try:
            h = structure.intersect([0.2, 0.3, 0.5], [0, 0, 1], tmin=-1)
            answers.append(("hit", bool(h.hit[0]), float(h.t[0]), int(h.triangle[0])))
        except ValueError as e:
            assert "tmin" in str(e)
            answers.append(("refused",))
    assert all(a == answers[0] for a in answers), answers
    if answers[0][0] == "hit":
        assert answers[0][1:3] == (True, -0.5)


@pytest.mark.parametrize("structure", STRUCTURES)
def test_bad_interval_is_refused_naming_the_parameter(structure):
    vertices, triangles = quad()
    s = raylab.build(vertices, triangles, structure)
    for tmin, tmax in ((math.nan, 1.0), (0.0, math.nan), (2.0, 1.0)):
        with pytest.raises(ValueError, match="tmin|tmax"):
            s.intersect([0.2, 0.3, 0.5], [0, 0, -1], tmin=tmin, tmax=tmax)


@pytest.mark.parametrize("z", [-1e-39, -2.8e-39, -1e-45, -0.0, 1e-45, 1e-39, -1e-30])
def test_tiny_direction_components_behave_like_zero(sphere, z):
    # Finding 5: the origin (-5, 0, 0) lies on every split plane of the sphere's octree.
    vertices, triangles = sphere
    for structure in STRUCTURES:
        s = raylab.build(vertices, triangles, structure, max_depth=8, leaf_size=1)
        zero = s.intersect([-5, 0, 0], [1, 0, 0])
        tiny = s.intersect([-5, 0, 0], [1, 0, z])
        assert tiny.hit[0] and zero.hit[0], structure
        assert (tiny.t[0], tiny.triangle[0]) == (zero.t[0], zero.triangle[0]), structure
        assert tiny.t[0] == pytest.approx(4.0, rel=1e-6)
        assert s.occluded([-5, 0, 0], [1, 0, z]).hit[0], structure


@pytest.mark.parametrize("triangle_test", ["watertight", "moller_trumbore"])
def test_no_hit_at_an_infinite_t_or_at_tmin(sphere, triangle_test):
    # Finding 6: directions so small that t overflows, rays lying in a flat mesh's plane, and
    # directions so large that Möller–Trumbore's products lose every digit.
    vertices, triangles = sphere
    flat = vertices.copy()
    flat[:, 2] = 0.0
    rng = np.random.default_rng(6)
    cases = [
        (vertices, np.tile([[-5, 0.01, 0.02]], (1, 1)), np.array([[1e-38, 1e-45, 0]])),
        (flat, rng.uniform(-1.5, 1.5, (2000, 3)) * [1, 1, 0], rng.normal(size=(2000, 3)) * [1, 1, 0]),
        (vertices, rng.uniform(-3, 3, (2000, 3)), rng.normal(size=(2000, 3)) * 1e15),
        (vertices, rng.uniform(-3, 3, (2000, 3)), rng.normal(size=(2000, 3)) * 1e30),
    ]
    for mesh, origins, directions in cases:
        origins, directions = origins.astype(np.float32), directions.astype(np.float32)
        for structure in STRUCTURES:
            h = raylab.build(mesh, triangles, structure, triangle_test=triangle_test).intersect(origins, directions)
            assert np.isfinite(h.t[h.hit]).all(), structure
            assert (h.t[h.hit] > 0).all(), structure
            assert not h.hit[0] or mesh is flat or directions[0, 0] != np.float32(1e-38), structure
    # The watertight test is exact enough that the structures also agree with brute force here.
    if triangle_test == "watertight":
        for mesh, origins, directions in cases:
            assert_all_equal_brute_force(mesh, triangles, origins.astype(np.float32), directions.astype(np.float32),
                                         "extreme directions")


def test_a_ray_lying_in_a_flat_mesh_plane_misses_it(sphere):
    vertices, triangles = sphere
    flat = vertices.copy()
    flat[:, 2] = 0.0
    rng = np.random.default_rng(66)
    origins = (rng.uniform(-1.5, 1.5, (2000, 3)) * [1, 1, 0]).astype(np.float32)
    directions = (rng.normal(size=(2000, 3)) * [1, 1, 0]).astype(np.float32)
    for structure in STRUCTURES:
        h = raylab.build(flat, triangles, structure).intersect(origins, directions)
        assert not h.hit.any(), structure


def test_coordinates_beyond_the_limit_are_refused_naming_the_vertex():
    # Finding 7: past 2^61 the float tests are no longer exact; such meshes are refused at build.
    vertices, triangles = quad(scale=1e19)
    for structure in STRUCTURES:
        with pytest.raises(ValueError, match=r"vertex 1 \(9\.9+\d*e\+18, 0, 0\).*2\^61"):
            raylab.build(vertices, triangles, structure)


@pytest.mark.parametrize("scale", [1e-30, 1e-10, 1e10, 1e18, 2.0 ** 61])
def test_coordinates_within_the_limit_are_hit_by_every_structure(scale):
    vertices, triangles = quad(z=1.0, scale=scale)
    rng = np.random.default_rng(7)
    n = 500
    origins = np.column_stack([rng.uniform(0, 1, n), rng.uniform(0, 1, n), np.full(n, 3.0)]) * scale
    origins = origins.astype(np.float32)
    directions = np.column_stack([rng.normal(0, 0.1, n), rng.normal(0, 0.1, n), -np.ones(n)]).astype(np.float32)
    reference = assert_all_equal_brute_force(vertices, triangles, origins, directions, f"scale {scale}")
    assert reference.hit.mean() > 0.5
    assert np.allclose(reference.t[reference.hit], 2.0 * scale, rtol=1e-5)  # t in units of the direction


def test_scene_instances_give_the_brute_force_hit_at_the_edges(sphere):
    # The exactness contract through a Scene's top level: flat instances under random rotations and
    # scales, rays from near and far that end exactly on the hit (tmax = t) or graze the plane near
    # the rim. The Scene with `none` (no top level) is the reference.
    vertices, triangles = sphere
    flat = vertices.copy()
    flat[:, 2] = 0.0
    rng = np.random.default_rng(10)
    for trial in range(4):
        scale = 10.0 ** rng.uniform(-3, 3)
        matrices = []
        for _ in range(4):
            rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            m = np.eye(4)
            m[:3, :3] = rotation * rng.uniform(0.5, 2, 3) * scale
            m[:3, 3] = rng.normal(size=3) * 3 * scale
            matrices.append(m)
        scenes = {}
        for s in STRUCTURES:
            scene = raylab.Scene(structure=s)
            ids = scene.add_mesh(flat, triangles), scene.add_mesh(vertices, triangles)
            for k, m in enumerate(matrices):
                scene.add_instance(ids[k % 2], m)
            scene.commit()
            scenes[s] = scene
        n = 400
        points = flat[rng.integers(0, len(flat), n)] * rng.uniform(0.9, 1.0, (n, 1))  # near the rim
        targets = (np.c_[points, np.ones(n)] @ matrices[0].T)[:, :3]
        grazing = np.c_[rng.normal(size=(n, 2)), -np.abs(rng.normal(size=n)) * 10.0 ** rng.uniform(-4, 0, n)]
        directions = grazing @ matrices[0][:3, :3].T
        distance = scale * 10.0 ** rng.uniform(-6, 4, (n, 1))
        origins = (targets - directions / np.linalg.norm(directions, axis=1, keepdims=True) * distance)
        origins, directions = origins.astype(np.float32), directions.astype(np.float32)
        reference = scenes["none"].intersect(origins, directions)
        occluded = scenes["none"].occluded(origins, directions).hit
        assert reference.hit.mean() > 0.8
        for name, scene in scenes.items():
            got = scene.intersect(origins, directions)
            bad = (got.hit != reference.hit) | (got.hit & reference.hit & (
                (got.t != reference.t) | (got.instance != reference.instance) | (got.triangle != reference.triangle)))
            assert not bad.any(), f"trial {trial}: {name} differs from none on {int(bad.sum())} rays"
            assert np.array_equal(scene.occluded(origins, directions).hit, occluded), f"trial {trial}: {name}"
        for i in np.flatnonzero(reference.hit)[:60]:
            for name, scene in scenes.items():
                h = scene.intersect(origins[i], directions[i], tmax=float(reference.t[i]))
                assert h.hit[0] and h.t[0] == reference.t[i], f"trial {trial}, ray {i}: {name} with tmax = t"
                assert scene.occluded(origins[i], directions[i], tmax=float(reference.t[i])).hit[0], name


@pytest.mark.parametrize("scale", [1e-30, 1e-16, 1e-15, 1.0, 1e13, 1e18])
def test_the_fast_contract_hits_a_triangles_interior_at_every_scale_and_its_queries_agree(scale):
    # Its triangle test multiplies three coordinates: unscaled, the products overflowed float beyond
    # meshes of about 1e12 (intersect missed, occluded hit) and fell into denormals below 1e-13.
    vertices = (np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0]]) * np.float32(scale)).astype(np.float32)
    triangles = np.uint32([[0, 1, 2]])
    origins = (np.float32([[0.25, 0.25, 1.0], [0.1, 0.6, 2.0], [0.7, 0.2, 0.5]]) * np.float32(scale))
    exact = raylab.build(vertices, triangles).intersect(origins.astype(np.float32), np.float32([0, 0, -1]))
    fast = raylab.build(vertices, triangles, contract="fast")
    hits = fast.intersect(origins.astype(np.float32), np.float32([0, 0, -1]))
    assert hits.hit.all() and exact.hit.all()
    np.testing.assert_allclose(hits.t, exact.t, rtol=1e-6)
    assert fast.occluded(origins.astype(np.float32), np.float32([0, 0, -1])).hit.all()


@pytest.mark.parametrize("scale", [1e-30, 1e-15, 1e18])
def test_the_fast_contract_on_a_scaled_mesh_finds_what_it_finds_at_scale_1(scale):
    vertices, triangles = load("bunny")
    unit_origins, directions = raylab.rays.camera_rays(vertices, 64)
    at_one = raylab.build(vertices, triangles, contract="fast").intersect(unit_origins, directions)
    scaled = (vertices * np.float32(scale)).astype(np.float32)
    origins, directions = raylab.rays.camera_rays(scaled, 64)
    for builder in raylab.BUILDERS:
        fast = raylab.build(scaled, triangles, contract="fast", builder=builder)
        hits = fast.intersect(origins, directions)
        assert hits.hit.sum() == at_one.hit.sum() > 500, builder
        assert (hits.triangle == at_one.triangle).mean() > 0.999, builder
        np.testing.assert_array_equal(fast.occluded(origins, directions).hit, hits.hit, err_msg=builder)
