"""Refit through the Python API: Structure.refit and Scene.refit_mesh give, on every frame of an
animated mesh, exactly the hits of a rebuild and of brute force, with counters and stories that agree;
bad vertices raise a ValueError naming them and change nothing; a Scene refits its top level when only
transforms change."""
import numpy as np
import pytest

import raylab
from raylab import animation, rays

from conftest import load

FRAMES = 24
STRESS = {8: "flattened", 12: "collapsed", 16: "mirrored"}


def frame_vertices(vertices, frame):
    """animation.twist_wave, and on three frames what stresses a refit most: the mesh flattened onto
    its centre's z plane (coplanar overlaps, triangles degenerate to segments), half of it collapsed
    onto one point (degenerate triangles), mirrored in x (every triangle flips its winding)."""
    v = animation.twist_wave(vertices, frame, FRAMES).astype(np.float64)
    centre = (v.min(axis=0) + v.max(axis=0)) / 2
    if STRESS.get(frame) == "flattened":
        v[:, 2] = centre[2]
    elif STRESS.get(frame) == "collapsed":
        v[v[:, 0] > centre[0]] = centre
    elif STRESS.get(frame) == "mirrored":
        v[:, 0] = 2 * centre[0] - v[:, 0]
    return v.astype(np.float32)


def frame_rays(vertices, triangles, frame):
    rng = np.random.default_rng(frame)
    sets = [rays.camera_rays(vertices, 24), rays.random_rays(vertices, 300, rng),
            rays.vertex_rays(vertices, triangles, 300, rng), rays.edge_midpoint_rays(vertices, triangles, 300, rng)]
    return np.concatenate([o for o, _ in sets]), np.concatenate([d for _, d in sets])


def assert_same_hits(a, b):
    for field in ("hit", "triangle", "t", "u", "v"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
@pytest.mark.parametrize("name", ["sphere", "spot_low_resolution"])
def test_every_frame_refit_equals_rebuild_and_brute_force(name, structure):
    rest, triangles = load(name)
    built = raylab.build(rest, triangles, structure=structure)
    chained = built
    for frame in range(FRAMES):
        vertices = frame_vertices(rest, frame)
        chained = chained.refit(vertices)
        assert chained.refitted == raylab.STRUCTURE_INFO[structure]["refits"]
        assert chained.structure == structure
        np.testing.assert_array_equal(chained.mesh()[0], vertices)
        origins, directions = frame_rays(vertices, triangles, frame)
        brute = raylab.build(vertices, triangles, structure="none").intersect(origins, directions)
        rebuilt = raylab.build(vertices, triangles, structure=structure)
        got = chained.intersect(origins, directions, count=True)
        assert_same_hits(got, brute)
        assert_same_hits(got, rebuilt.intersect(origins, directions))
        assert_same_hits(built.refit(vertices).intersect(origins, directions), brute)  # from the rest pose
        np.testing.assert_array_equal(chained.occluded(origins, directions).hit, brute.hit)
        # A story tells what the counted query did.
        for i in range(0, len(origins), 97):
            story = chained.story(origins[i], directions[i])
            one = chained.intersect(origins[i:i + 1], directions[i:i + 1], count=True)
            assert story.stats == one.stats
            assert (story.hit is not None) == bool(one.hit[0])
        assert got.stats["rays"] == len(origins)


def test_refit_keeps_the_topology_and_the_rebuild_may_not():
    rest, triangles = load("bunny")
    built = raylab.build(rest, triangles)
    vertices = animation.twist_wave(rest, FRAMES - 1, FRAMES)
    refitted, rebuilt = built.refit(vertices), raylab.build(vertices, triangles)
    a, b = built.boxes(), refitted.boxes()
    for field in ("depth", "leaf", "triangle_count"):
        np.testing.assert_array_equal(a[field], b[field])
    # The refitted boxes hold the moved triangles: the root is the moved mesh's box.
    np.testing.assert_array_equal(b["lo"][0], vertices.min(axis=0))
    np.testing.assert_array_equal(b["hi"][0], vertices.max(axis=0))
    assert built.sah_cost() == built.refit(rest).sah_cost()
    assert refitted.sah_cost() > 0 and rebuilt.sah_cost() > 0
    assert raylab.build(rest, triangles, structure="octree").sah_cost() is None


def test_scrambled_vertices_degrade_the_refit_sah_cost():
    rest, triangles = load("bunny")
    scrambled = np.random.default_rng(3).permutation(rest)
    refitted = raylab.build(rest, triangles).refit(scrambled)
    assert refitted.sah_cost() > 1.25 * raylab.build(scrambled, triangles).sah_cost()  # C++ test: 1373 vs 908


@pytest.mark.parametrize("bad, words", [
    (lambda v: v[:-1], "vertices: expected"),
    (lambda v: np.where(np.arange(len(v))[:, None] == 4, np.nan, v), "vertices: vertex 4"),
    (lambda v: np.where(np.arange(len(v))[:, None] == 2, np.inf, v), "vertices: vertex 2"),
    (lambda v: v * 1e30, "vertices: vertex"),
    (lambda v: v[:, :2], "vertices must have shape (N, 3)"),
    (lambda v: None, "vertices must be an array"),
    (lambda v: v.astype(np.complex64), "vertices must have a real number dtype"),
])
def test_bad_vertices_raise_naming_them_and_change_nothing(sphere, bad, words):
    rest, triangles = sphere
    built = raylab.build(rest, triangles)
    boxes = built.boxes()
    with pytest.raises(ValueError, match=words.replace("(", r"\(").replace(")", r"\)")):
        built.refit(bad(rest.copy()))
    np.testing.assert_array_equal(built.boxes()["lo"], boxes["lo"])
    np.testing.assert_array_equal(built.mesh()[0], rest)

    scene = raylab.Scene()
    m = scene.add_mesh(rest, triangles)
    scene.add_instance(m, np.eye(4))
    scene.commit()
    with pytest.raises(ValueError, match=words.replace("(", r"\(").replace(")", r"\)")):
        scene.refit_mesh(m, bad(rest.copy()))
    hits = scene.intersect([0, 0, 5], [0, 0, -1])  # still committed: no change was made
    assert hits.hit[0]
    with pytest.raises(ValueError, match="mesh"):
        scene.refit_mesh(3, rest)


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_scene_follows_an_animation_and_refits_its_top_level(structure):
    rest, triangles = load("sphere")
    scene = raylab.Scene(structure=structure)
    m = scene.add_mesh(rest, triangles)
    for k in range(3):
        scene.add_instance(m, _place(k, 0))
    scene.commit()
    assert scene.top_level_update == "built"
    origins, directions = rays.camera_rays(np.array([[-1.5, -1.5, -1], [7.5, 1.5, 1]], np.float32), 40)
    for frame in range(1, 12):
        vertices = animation.twist_wave(rest, frame, 12)
        scene.refit_mesh(m, vertices)
        for k in range(3):
            scene.set_transform(k, _place(k, frame))
        scene.commit()
        assert scene.top_level_update == "refitted"
        assert scene.structure(m).refitted == raylab.STRUCTURE_INFO[structure]["refits"]
        fresh = raylab.Scene(structure=structure)
        fm = fresh.add_mesh(vertices, triangles)
        for k in range(3):
            fresh.add_instance(fm, _place(k, frame))
        fresh.commit()
        a, b = scene.intersect(origins, directions), fresh.intersect(origins, directions)
        assert_same_hits(a, b)
        np.testing.assert_array_equal(a.instance, b.instance)
    scene.commit()
    assert scene.top_level_update == "kept"
    assert scene.top_level_sah_cost > 0
    assert raylab.TOP_LEVEL_REFIT_LIMIT > 1


def _place(k, frame):
    m = np.eye(4, dtype=np.float32)
    m[0, 3] = 3.0 * k
    m[1, 3] = 0.3 * np.sin(0.4 * (frame + k))
    return m
