"""The uncounted batch queries (the numpy door: coherent rays traced as packets, a packet or a scene's
group of rays that all miss the root box answered after one box test) give every ray what it gets
alone: the counted query walks each ray by itself, and its hits must be the same bit for bit, on rays
that miss the root whole (the sky around a camera's subject), graze it, or stop short of it."""
import numpy as np
import pytest

import raylab
from raylab import rays

from conftest import load
from test_scene import rotate_z, translate

FIELDS = ("t", "u", "v", "triangle", "instance", "hit")
# Every structure in the exact contract with each triangle test, and the fast contract where a structure
# takes it (its own triangle test).
SETTINGS = [(s, c, t) for s in raylab.STRUCTURES for c in raylab.CONTRACTS for t in raylab.TRIANGLE_TESTS
            if (c == "exact" or raylab.STRUCTURE_INFO[s]["uses_contract"]) and (c == "exact" or t == "watertight")]


def camera_batches(vertices):
    """Camera rays with sky all around the mesh (a wide view), the same rays cut short before the mesh
    (tmax) and started beyond it (tmin), and rays shared from one origin in one direction (a (3,) row)."""
    o, d = rays.camera_rays(vertices, 48)
    lo, hi = vertices.min(0), vertices.max(0)
    wide = d.copy()
    wide[:, :2] *= 3.0  # three times the field of view: most groups of rays see only sky
    size = float(np.linalg.norm(hi - lo))
    distance = float(np.linalg.norm(o[0] - (lo + hi) / 2))
    return [
        (o, wide, 0.0, np.inf),
        (o, d, 0.0, distance - 0.45 * size),  # ends before the mesh for most rays, inside it for some
        (o, d, distance - 0.1 * size, np.inf),
        (o[0], d[len(d) // 2], 0.0, np.inf),
    ]


def same_hits(alone, batch):
    for field in FIELDS:
        a, b = getattr(alone, field), getattr(batch, field)
        assert a.dtype == b.dtype and np.array_equal(a.view(np.uint8), b.view(np.uint8)), field


@pytest.mark.parametrize("structure, contract, triangle_test", SETTINGS)
def test_a_structures_batch_answers_as_each_ray_alone(structure, contract, triangle_test):
    bunny = load("bunny")
    s = raylab.build(*bunny, structure=structure, contract=contract, triangle_test=triangle_test)
    for origins, directions, tmin, tmax in camera_batches(bunny[0]):
        same_hits(s.intersect(origins, directions, tmin, tmax, count=True),
                  s.intersect(origins, directions, tmin, tmax))
        alone = s.occluded(origins, directions, tmin, tmax, count=True).hit
        assert np.array_equal(alone, s.occluded(origins, directions, tmin, tmax).hit)


@pytest.mark.parametrize("structure, contract, triangle_test", SETTINGS)
def test_a_scenes_batch_answers_as_each_ray_alone(structure, contract, triangle_test):
    bunny = load("bunny")
    scene = raylab.Scene(structure=structure, contract=contract, triangle_test=triangle_test)
    mesh = scene.add_mesh(*bunny)
    scene.add_instance(mesh, np.eye(4))
    scene.add_instance(mesh, translate(0.3, 0.1, scale=0.5) @ rotate_z(30))
    scene.commit()
    for origins, directions, tmin, tmax in camera_batches(bunny[0]):
        same_hits(scene.intersect(origins, directions, tmin, tmax, count=True),
                  scene.intersect(origins, directions, tmin, tmax))
        alone = scene.occluded(origins, directions, tmin, tmax, count=True).hit
        assert np.array_equal(alone, scene.occluded(origins, directions, tmin, tmax).hit)
