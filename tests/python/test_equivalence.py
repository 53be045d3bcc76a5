"""Every structure returns the brute-force closest hit (same triangle, same t) and the same any-hit
answer, on every shipped mesh, for about 100k rays per mesh of the kinds where naive methods fail:
camera and random rays, rays aimed at vertices and edge midpoints, axis-parallel rays on split
planes, grazing rays and rays starting inside the mesh."""
import functools

import numpy as np
import pytest

import raylab
import rays
from conftest import MESHES, load

SEED = 20261122
# Brute force is quadratic: above this many triangles it checks a fixed subset of the rays, and the
# fast structures are checked against each other on all of them.
BRUTE_FORCE_TRIANGLES = 50_000
BRUTE_FORCE_SUBSET = 10_000
# `aabb` tests every triangle of every ray that enters the box: as slow as brute force, so it is
# checked on a subset as well.
AABB_SUBSET = 20_000


@functools.lru_cache(maxsize=None)
def case(name):
    """Rays for mesh `name` and the brute-force answers on the checked rays."""
    vertices, triangles = load(name)
    origins, directions, family = rays.mixed_rays(vertices, triangles, SEED)
    n = len(origins)
    if len(triangles) > BRUTE_FORCE_TRIANGLES:
        checked = np.sort(np.random.default_rng(SEED).choice(n, BRUTE_FORCE_SUBSET, replace=False))
    else:
        checked = np.arange(n)
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


def test_mixed_rays_are_many_and_of_every_kind():
    origins, directions, family, _, _ = case("sphere")
    assert len(origins) >= 100_000
    assert set(family) == {"camera", *rays.FAMILIES}


@pytest.mark.parametrize("name", MESHES)
@pytest.mark.parametrize("structure", ["aabb", "octree", "bvh"])
def test_closest_and_any_hit_equal_brute_force(name, structure):
    vertices, triangles = load(name)
    origins, directions, family, checked, reference = case(name)
    if structure == "aabb" and len(checked) > AABB_SUBSET:
        keep = np.linspace(0, len(checked) - 1, AABB_SUBSET).astype(int)
        checked = checked[keep]
        reference = raylab.Hits({k: getattr(reference, k)[keep] if k != "stats" else None
                                 for k in raylab.Hits.__slots__})
    s = raylab.build(vertices, triangles, structure)
    o, d, f = origins[checked], directions[checked], family[checked]
    assert_same_hits(s.intersect(o, d), reference, f, f"{structure} on {name}")
    # The counting path is the same traversal with another recorder: it must find the same hits.
    assert_same_hits(s.intersect(o, d, count=True), reference, f, f"{structure} (counting) on {name}")
    occluded = s.occluded(o, d).hit
    differs = np.flatnonzero(occluded != reference.hit)
    assert len(differs) == 0, (f"{structure} on {name}: any-hit disagrees with brute force on {len(differs)} "
                               f"rays, first ray {differs[:1]} ({f[differs[:1]]})")


@pytest.mark.parametrize("name", [m for m in MESHES if len(load(m)[1]) > BRUTE_FORCE_TRIANGLES])
def test_octree_and_bvh_agree_on_every_ray(name):
    vertices, triangles = load(name)
    origins, directions, family, _, _ = case(name)
    octree = raylab.build(vertices, triangles, "octree")
    bvh = raylab.build(vertices, triangles, "bvh")
    assert_same_hits(octree.intersect(origins, directions), bvh.intersect(origins, directions), family,
                     f"octree against bvh on {name}")
    assert np.array_equal(octree.occluded(origins, directions).hit, bvh.occluded(origins, directions).hit)
