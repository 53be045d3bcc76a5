"""No ray escapes a closed mesh from inside: rays from interior points aimed exactly at vertices, edge
midpoints and other points on edges, where a non-watertight triangle test lets rays slip between two
triangles. Möller–Trumbore's escapes are counted and printed (they are allowed: showing them is part
of the teaching)."""
import functools

import numpy as np
import pytest

import raylab
from raylab import rays
from conftest import CLOSED_MESHES, load

SEED = 4242
TARGETS_PER_KIND = 4000  # per interior point: vertices, edge midpoints, random points on edges
INTERIOR_POINTS = 3
# Brute force and `aabb` test every triangle per ray: they trace an evenly spread subset of the rays
# within this many triangle tests.
SLOW_STRUCTURE_TESTS = 50_000_000


def crossings(structure, origin, direction):
    """How many times the ray from `origin` crosses the surface: hits are followed one after another
    by restarting the search just beyond the last one."""
    count, tmin = 0, 0.0
    while True:
        h = structure.intersect(origin, direction, tmin=tmin)
        if not h.hit[0]:
            return count
        count, tmin = count + 1, float(h.t[0])


@functools.lru_cache(maxsize=None)
def interior_points(name):
    """Points just behind faces (along the inward normal) that the parity of surface crossings along
    five random rays (all odd) proves to be inside the closed mesh."""
    vertices, triangles = load(name)
    rng = np.random.default_rng(SEED)
    reference = raylab.build(vertices, triangles, "none")  # independent of the structures under test
    p = vertices[triangles].astype(np.float64)
    # The sign of the enclosed volume says whether the normals point outwards.
    outward = np.sign(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum())
    lo, hi = rays.bounds(vertices)
    found = []
    for _ in range(200):
        centroid, normal = rays.triangle_frames(vertices, triangles, rng.integers(0, len(triangles), 1))
        if not np.isfinite(normal).all():
            continue
        candidate = (centroid - outward * 1e-3 * np.linalg.norm(hi - lo) * normal)[0]
        if all(crossings(reference, candidate, d) % 2 == 1 for d in rays.random_directions(rng, 5)):
            found.append(candidate)
            if len(found) == INTERIOR_POINTS:
                return np.array(found)
    pytest.fail(f"no point inside {name} found")


@functools.lru_cache(maxsize=None)
def watertight_rays(name):
    """Rays from each interior point through vertices, edge midpoints and random points on edges."""
    vertices, triangles = load(name)
    rng = np.random.default_rng(SEED)
    origins, directions = [], []
    for point in interior_points(name):
        targets = np.concatenate([
            vertices[rng.choice(len(vertices), min(TARGETS_PER_KIND, len(vertices)), replace=False)],
            rays.edge_points(vertices, triangles, TARGETS_PER_KIND, rng, where=0.5),
            rays.edge_points(vertices, triangles, TARGETS_PER_KIND, rng)])
        o, d = rays.aimed_rays(np.broadcast_to(point, targets.shape), targets.astype(np.float64))
        origins.append(o)
        directions.append(d)
    return np.concatenate(origins), np.concatenate(directions)


def traced_rays(name, structure):
    origins, directions = watertight_rays(name)
    triangles = len(load(name)[1])
    if structure in ("none", "aabb") and len(origins) * triangles > SLOW_STRUCTURE_TESTS:
        keep = np.linspace(0, len(origins) - 1, SLOW_STRUCTURE_TESTS // triangles).astype(np.int64)
        return origins[keep], directions[keep]
    return origins, directions


@pytest.mark.parametrize("name", CLOSED_MESHES)
@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_no_ray_escapes_a_closed_mesh(name, structure):
    vertices, triangles = load(name)
    origins, directions = traced_rays(name, structure)
    h = raylab.build(vertices, triangles, structure).intersect(origins, directions)
    escaped = np.flatnonzero(~h.hit)
    assert len(escaped) == 0, (f"{len(escaped)} of {len(origins)} rays escaped {name} through {structure}; "
                               f"first: origin {origins[escaped[0]]}, direction {directions[escaped[0]]}")
    assert raylab.build(vertices, triangles, structure).occluded(origins, directions).hit.all()

    leaky = raylab.build(vertices, triangles, structure, triangle_test="moller_trumbore")
    leaks = int((~leaky.intersect(origins, directions).hit).sum())
    print(f"\n{name} {structure}: moller_trumbore lets {leaks} of {len(origins)} rays escape "
          f"(watertight: 0)")


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_no_ray_escapes_from_the_centre_lying_on_every_split_plane(structure):
    """From the sphere's centre, which lies on the octree's and the BVH's split planes, rays through
    every vertex: many have direction components of exactly 0 or -0, so they lie in box face planes."""
    vertices, triangles = load("sphere")
    centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
    directions = (vertices - centre).astype(np.float32)
    assert (np.signbit(directions) & (directions == 0)).any(), "the case needs -0 components"
    origins = np.broadcast_to(centre, directions.shape).astype(np.float32)
    h = raylab.build(vertices, triangles, structure).intersect(origins, directions)
    assert h.hit.all(), f"{int((~h.hit).sum())} rays escaped through {structure}"
