"""Every structure returns the brute-force closest hit (same triangle, same t) and the same any-hit
answer, on every shipped mesh. About 100k rays per mesh, of the kinds where naive methods fail:
camera and random rays, rays aimed at vertices and edge midpoints, axis-parallel rays on split
planes, grazing rays and rays starting inside the mesh. Brute force checks every ray on meshes up to
50k triangles and an evenly spread 2,500 of them above, where the structures agree with each other on
all rays."""
import functools
import os

import numpy as np
import pytest

import raylab
from raylab import rays
from conftest import MESHES, load

SEED = 20261122
# Brute force costs rays x triangles tests (10 to 50 ns each on the 2 shared cores), and so does
# `aabb` for rays entering the box: above this size they check LARGE_MESH_RAYS evenly spread rays
# (every family: the smallest spans more rays than the spacing).
LARGE_MESH_TRIANGLES = 50_000
LARGE_MESH_RAYS = 2_500
# ./raylab test --sanitize sets RAYLAB_BRUTE_FORCE_SAMPLED=1: every mesh checks the spread rays (under ASan
# brute force would take most of the pass, and memory errors do not depend on how many rays it checks).
SAMPLED_ONLY = os.environ.get("RAYLAB_BRUTE_FORCE_SAMPLED") == "1"


@functools.lru_cache(maxsize=None)
def case(name):
    """Rays for mesh `name`, the subset brute force checks, and its answers there."""
    vertices, triangles = load(name)
    origins, directions, family = rays.mixed_rays(vertices, triangles, SEED)
    n = len(origins)
    m = n if len(triangles) <= LARGE_MESH_TRIANGLES and not SAMPLED_ONLY else min(n, LARGE_MESH_RAYS)
    checked = np.linspace(0, n - 1, m).astype(np.int64)
    reference = raylab.build(vertices, triangles, "none").intersect(origins[checked], directions[checked])
    return origins, directions, family, checked, reference


def assert_same_hits(got, expected, family, what):
    t_differs = ~np.isclose(got.t, expected.t, rtol=1e-5, atol=0.0)
    bad = (got.triangle != expected.triangle) | t_differs | (got.hit != expected.hit)
    if bad.any():
        i = np.flatnonzero(bad)
        by_family = {f: int((family[i] == f).sum()) for f in np.unique(family[i])}
        first = i[0]
        pytest.fail(f"{what}: {len(i)} of {len(bad)} rays differ {by_family}; first: ray {first} "
                    f"({family[first]}) triangle {got.triangle[first]} t {got.t[first]!r}, expected "
                    f"triangle {expected.triangle[first]} t {expected.t[first]!r}")
    same = got.hit
    assert np.allclose(got.u[same], expected.u[same], atol=1e-5), f"{what}: barycentric u differs"
    assert np.allclose(got.v[same], expected.v[same], atol=1e-5), f"{what}: barycentric v differs"


@pytest.mark.parametrize("name", MESHES)
def test_rays_are_many_and_brute_force_sees_every_kind(name):
    origins, directions, family, checked, _ = case(name)
    assert len(origins) >= 100_000
    assert set(family[checked]) == {"camera", *rays.FAMILIES}


@pytest.mark.parametrize("name", MESHES)
@pytest.mark.parametrize("structure", [s for s in raylab.STRUCTURES if s != "none"])  # held to none
def test_closest_and_any_hit_equal_brute_force(name, structure):
    vertices, triangles = load(name)
    origins, directions, family, checked, reference = case(name)
    s = raylab.build(vertices, triangles, structure)
    o, d, f = origins[checked], directions[checked], family[checked]
    assert_same_hits(s.intersect(o, d), reference, f, f"{structure} on {name}")
    if structure != "aabb":  # (aabb's counting is checked in test_api: here it would only cost time)
        # The counting path is the same traversal with another recorder: it must find the same hits.
        assert_same_hits(s.intersect(o, d, count=True), reference, f, f"{structure} (counting) on {name}")
    occluded = s.occluded(o, d).hit
    differs = np.flatnonzero(occluded != reference.hit)
    assert len(differs) == 0, (f"{structure} on {name}: any-hit disagrees with brute force on {len(differs)} "
                               f"rays, first ray {differs[:1]} ({f[differs[:1]]})")


@pytest.mark.parametrize("name", MESHES)
def test_octree_and_bvh_agree_on_every_ray(name):
    vertices, triangles = load(name)
    origins, directions, family, _, _ = case(name)
    octree = raylab.build(vertices, triangles, "octree")
    bvh = raylab.build(vertices, triangles, "bvh")
    assert_same_hits(octree.intersect(origins, directions), bvh.intersect(origins, directions), family,
                     f"octree against bvh on {name}")
    assert np.array_equal(octree.occluded(origins, directions).hit, bvh.occluded(origins, directions).hit)


SMALL_MESHES = [name for name in MESHES if len(load(name)[1]) <= 20_000]  # the builders' quick pass


@pytest.mark.parametrize("name", SMALL_MESHES)
@pytest.mark.parametrize("builder", [b for b in raylab.BUILDERS if b != raylab.DEFAULTS["builder"]])  # sah above
def test_every_bvh_builder_equals_brute_force(name, builder):
    vertices, triangles = load(name)
    origins, directions, family, checked, reference = case(name)
    s = raylab.build(vertices, triangles, "bvh", builder=builder)
    assert s.builder == builder
    o, d, f = origins[checked], directions[checked], family[checked]
    assert_same_hits(s.intersect(o, d), reference, f, f"bvh ({builder}) on {name}")
    assert_same_hits(s.intersect(o, d, count=True), reference, f, f"bvh ({builder}, counting) on {name}")
    assert np.array_equal(s.occluded(o, d).hit, reference.hit), f"bvh ({builder}) on {name}: any-hit differs"
