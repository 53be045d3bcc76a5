"""Per-ray counters: intersect/occluded(per_ray=True) give each ray's own work, for a Structure and a
Scene, from the same counting as the totals (count=True)."""
import numpy as np
import pytest

import raylab
from conftest import load

STRUCTURES = raylab.STRUCTURES
QUERIES = ("intersect", "occluded")


def mixed_rays(vertices, n, seed):
    """Rays from outside at points inside the box (half hit, some graze) and rays pointing away."""
    rng = np.random.default_rng(seed)
    lo, hi = raylab.rays.bounds(vertices)
    origins = raylab.rays.outside_points(vertices, n, rng)
    targets = rng.uniform(lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo), (n, 3))
    directions = targets - origins
    directions[::5] *= -1  # these miss the root box
    return origins.astype(np.float32), directions.astype(np.float32)


def translate(x):
    m = np.eye(4, dtype=np.float32)
    m[0, 3] = x
    return m


def two_instance_scene(structure):
    vertices, triangles = load("bunny")
    scene = raylab.Scene(structure=structure)
    mesh = scene.add_mesh(vertices, triangles)
    scene.add_instance(mesh, np.eye(4, dtype=np.float32))
    scene.add_instance(mesh, translate(0.1))  # overlapping: rays query both
    scene.commit()
    return scene


def targets(structure):
    vertices, _ = load("bunny")
    return {"structure": raylab.build(*load("bunny"), structure=structure),
            "scene": two_instance_scene(structure)}, vertices


@pytest.mark.parametrize("target", ["structure", "scene"])
@pytest.mark.parametrize("query", QUERIES)
@pytest.mark.parametrize("structure", STRUCTURES)
def test_per_ray_counts_sum_to_the_totals_and_leave_the_answers_alone(structure, query, target):
    built, vertices = targets(structure)
    t = built[target]
    o, d = mixed_rays(vertices, 600, 1)
    plain = getattr(t, query)(o, d)
    counted = getattr(t, query)(o, d, count=True)
    each = getattr(t, query)(o, d, per_ray=True)
    assert plain.per_ray is None and counted.per_ray is None
    assert tuple(each.per_ray) == raylab.COUNTERS
    for name, values in each.per_ray.items():
        assert values.dtype == np.uint32 and values.shape == (600,)
        assert int(values.sum(dtype=np.uint64)) == counted.stats[name] == each.stats[name], name
    assert (each.per_ray["rays"] >= 1).all()
    assert (each.hit == plain.hit).all()
    if query == "intersect":
        assert (each.triangle == plain.triangle).all() and (each.t == plain.t).all()
        assert (each.instance == plain.instance).all()
    if structure != "none":  # some rays missed the root box, and tested nothing
        ignored = each.per_ray["rays_ignored"] > 0
        assert ignored.any() and (each.per_ray["triangle_tests"][ignored] == 0).all()


@pytest.mark.parametrize("target", ["structure", "scene"])
@pytest.mark.parametrize("query", QUERIES)
@pytest.mark.parametrize("structure", STRUCTURES)
def test_each_rays_counts_equal_a_call_with_that_ray_alone(structure, query, target):
    built, vertices = targets(structure)
    t = built[target]
    o, d = mixed_rays(vertices, 40, 2)
    each = getattr(t, query)(o, d, per_ray=True).per_ray
    for i in range(len(o)):
        alone = getattr(t, query)(o[i:i + 1], d[i:i + 1], count=True).stats
        assert {name: int(each[name][i]) for name in raylab.COUNTERS} == alone, f"ray {i}"


@pytest.mark.parametrize("query", QUERIES)
@pytest.mark.parametrize("structure", STRUCTURES)
def test_per_ray_counts_are_the_same_on_any_thread_count(structure, query):
    built, vertices = targets(structure)
    o, d = mixed_rays(vertices, 3000, 3)
    for t in built.values():
        one = getattr(t, query)(o, d, per_ray=True, threads=1)
        all_cores = getattr(t, query)(o, d, per_ray=True, threads=None)
        two = getattr(t, query)(o, d, per_ray=True, threads=2)
        for name in raylab.COUNTERS:
            assert (one.per_ray[name] == all_cores.per_ray[name]).all()
            assert (one.per_ray[name] == two.per_ray[name]).all()
        assert one.stats == two.stats == all_cores.stats


def test_per_ray_must_be_true_or_false(sphere):
    s = raylab.build(*sphere)
    with pytest.raises(ValueError, match="per_ray"):
        s.intersect([0, 0, -5], [0, 0, 1], per_ray="yes")
    with pytest.raises(ValueError, match="per_ray"):
        s.occluded([0, 0, -5], [0, 0, 1], per_ray=2)


def test_no_rays_give_empty_per_ray_arrays(sphere):
    s = raylab.build(*sphere)
    h = s.intersect(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32), per_ray=True)
    assert all(v.shape == (0,) and v.dtype == np.uint32 for v in h.per_ray.values())
    assert all(v == 0 for v in h.stats.values())
