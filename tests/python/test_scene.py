"""raylab.Scene: instances of shared meshes under 4x4 row-major transforms, world-space hits with the
instance that was hit, changes that need a commit(), and clear errors for bad ids and matrices."""
import numpy as np
import pytest

import raylab
from raylab import rays


def translate(x, y=0.0, z=0.0, scale=1.0):
    m = np.diag([scale, scale, scale, 1.0])
    m[:3, 3] = (x, y, z)  # row-major: the translation is the last column
    return m


def rotate_z(degrees):
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    m = np.eye(4)
    m[:2, :2] = [[c, -s], [s, c]]
    return m


@pytest.fixture
def two_spheres(sphere):
    """Instance 0: the unit sphere at x = -3; instance 1: the same mesh, twice as large, at x = +3."""
    def make(structure):
        scene = raylab.Scene(structure=structure)
        m = scene.add_mesh(*sphere)
        assert scene.add_instance(m, translate(-3), material=0) == 0
        assert scene.add_instance(m, translate(3, scale=2), material=1) == 1
        scene.commit()
        return scene
    return make


RAYS = (np.array([[-3, 0, -10], [3, 0, -10], [0, 0, -10]], np.float32), np.array([0, 0, 1], np.float32))


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_hits_name_the_instance_and_use_world_distances(two_spheres, structure):
    scene = two_spheres(structure)
    h = scene.intersect(*RAYS, count=True)
    assert list(h.hit) == [True, True, False]
    assert list(h.instance) == [0, 1, -1]
    assert h.t[0] == pytest.approx(9.0, rel=1e-3) and h.t[1] == pytest.approx(8.0, rel=1e-3)
    assert h.stats["rays"] == 3
    assert list(scene.occluded(*RAYS).hit) == [True, True, False]
    assert list(scene.occluded(*RAYS, tmax=8.5).hit) == [False, True, False]
    assert (scene.mesh_count, scene.instance_count) == (1, 2)
    lo, hi = scene.bounds()
    assert np.allclose(lo, [-4, -2, -2], atol=1e-5) and np.allclose(hi, [5, 2, 2], atol=1e-5)


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_an_instance_hits_what_its_transformed_mesh_hits(sphere, structure):
    vertices, triangles = sphere
    matrix = translate(0.5, -0.25, 1.0, scale=1.5) @ rotate_z(30)
    scene = raylab.Scene(structure=structure)
    scene.add_instance(scene.add_mesh(vertices, triangles), matrix)
    scene.commit()
    world = (np.c_[vertices, np.ones(len(vertices))] @ matrix.T)[:, :3].astype(np.float32)
    o, d = rays.camera_rays(world, 64)
    expected = raylab.build(world, triangles, structure=structure).intersect(o, d)
    h = scene.intersect(o, d)
    # Rays moved into object space round differently: only silhouette rays may change their answer.
    assert (h.hit != expected.hit).sum() <= 3
    both = h.hit & expected.hit
    assert np.allclose(h.t[both], expected.t[both], rtol=1e-4)
    assert (h.instance[h.hit] == 0).all()


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_moving_an_instance_needs_a_commit_and_moves_its_hits(two_spheres, structure):
    scene = two_spheres(structure)
    scene.set_transform(0, translate(10))
    with pytest.raises(RuntimeError, match="commit"):
        scene.intersect(*RAYS)
    scene.commit()
    assert list(scene.intersect(*RAYS).hit) == [False, True, False]


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_a_replaced_mesh_changes_every_instance(two_spheres, sphere, structure):
    scene = two_spheres(structure)
    scene.replace_mesh(0, sphere[0] * 0.5, sphere[1])
    scene.commit()
    h = scene.intersect(*RAYS)
    assert h.t[0] == pytest.approx(9.5, rel=1e-3) and h.t[1] == pytest.approx(9.0, rel=1e-3)


@pytest.mark.parametrize("structure", [s for s, info in raylab.STRUCTURE_INFO.items() if info["uses_top_level"]])
def test_instances_share_their_mesh_structure(sphere, structure):
    def memory(instances):
        scene = raylab.Scene(structure=structure)
        m = scene.add_mesh(*sphere)
        for i in range(instances):
            scene.add_instance(m, translate(3 * i))
        scene.commit()
        return scene.memory_bytes
    one_structure = raylab.build(*sphere, structure=structure).memory_bytes
    assert memory(1) >= one_structure
    assert memory(10) - memory(1) < one_structure


BAD_SCENE_CALLS = {
    "unknown mesh": (lambda s: s.add_instance(5, np.eye(4)), "unknown mesh id 5"),
    "negative mesh": (lambda s: s.add_instance(-1, np.eye(4)), "unknown mesh id -1"),
    "unknown instance": (lambda s: s.set_transform(3, np.eye(4)), "unknown instance id 3"),
    "matrix shape": (lambda s: s.add_instance(0, np.eye(3)), "(4, 4)"),
    "singular matrix": (lambda s: s.add_instance(0, np.diag([1.0, 0.0, 1.0, 1.0])), "singular"),
    "NaN matrix": (lambda s: s.add_instance(0, np.full((4, 4), np.nan)), "NaN"),
    "negative material": (lambda s: s.add_instance(0, np.eye(4), material=-2), "material"),
    "bad mesh": (lambda s: s.add_mesh(np.zeros((3, 3)), np.array([[0, 1, 7]])), "triangle 0 refers to vertex 7"),
    "replace unknown mesh": (lambda s: s.replace_mesh(2, np.zeros((3, 3)), np.array([[0, 1, 2]])), "unknown mesh id 2"),
    "zero direction": (lambda s: s.intersect([0, 0, 0], [0, 0, 0]), "zero length"),
}


@pytest.mark.parametrize("case", BAD_SCENE_CALLS, ids=list(BAD_SCENE_CALLS))
def test_bad_scene_calls_raise_value_errors(sphere, case):
    scene = raylab.Scene()
    scene.add_mesh(*sphere)
    scene.commit()
    call, message = BAD_SCENE_CALLS[case]
    with pytest.raises(ValueError) as error:
        call(scene)
    assert message in str(error.value)


def test_bad_scene_settings_raise_value_errors():
    with pytest.raises(ValueError, match="unknown structure"):
        raylab.Scene(structure="kdtree")
    with pytest.raises(ValueError, match="leaf_size"):
        raylab.Scene(leaf_size=0)
    with pytest.raises(ValueError, match="max_depth"):
        raylab.Scene().set_settings(structure="octree", max_depth=-3)


def test_new_settings_rebuild_the_structures(two_spheres):
    scene = two_spheres("bvh")
    expected = scene.intersect(*RAYS)
    scene.set_settings(structure="octree", max_depth=3)
    scene.commit()
    h = scene.intersect(*RAYS, count=True)
    assert np.array_equal(h.triangle, expected.triangle) and np.array_equal(h.instance, expected.instance)


@pytest.mark.parametrize("scale", [1e-13, 1e-20])
def test_a_tiny_uniform_scale_is_invertible_and_hit(sphere, scale):
    """A uniform scale far below 1 is invertible (its inverse fits a float); only one whose inverse would
    overflow float is refused."""
    scene = raylab.Scene(structure="bvh")
    m = scene.add_mesh(*sphere)
    scene.add_instance(m, translate(0, scale=scale))
    scene.commit()
    hits = scene.intersect(np.array([[0, 0, -1]], np.float32), np.array([0, 0, 1], np.float32))
    assert hits.hit[0] and abs(hits.t[0] - (1 - scale)) <= 1e-6
    with pytest.raises(ValueError, match="overflows"):
        scene.add_instance(m, translate(0, scale=1e-40))


def _random_world_rays(count, seed):
    rng = np.random.default_rng(seed)
    origins = rng.uniform(-8, 8, (count, 3)).astype(np.float32)
    targets = rng.uniform(-3, 4, (count, 3)).astype(np.float32)  # mostly towards the two spheres
    return origins, (targets - origins).astype(np.float32)


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_a_scene_story_is_what_intersect_did_for_that_ray(two_spheres, structure):
    """The story's hit, instance and counters are the batch query's, ray by ray; its status is the
    batch statuses'; each instance part is that instance's own story of the ray in object space."""
    scene = two_spheres(structure)
    origins, directions = _random_world_rays(300, seed=5)
    batch = scene.statuses(origins, directions)
    seen = set()
    for i in range(len(origins)):
        st = scene.story(origins[i], directions[i])
        one = scene.intersect(origins[i], directions[i], count=True)
        assert st.stats == one.stats
        assert raylab.RAY_STATUSES.index(st.status) == batch.status[i]
        seen.add(st.status)
        if one.hit[0]:
            assert (st.hit["t"], st.hit["triangle"], st.hit["instance"]) == (one.t[0], one.triangle[0], one.instance[0])
            assert (batch.t[i], batch.instance[i]) == (one.t[0], one.instance[0])
            assert np.allclose(st.hit["point"], origins[i] + one.t[0] * directions[i], atol=1e-4)
        else:
            assert st.hit is None and not batch.hit[i]
        object_work = sum(p.story.stats["triangle_tests"] for p in st.instances)
        assert object_work == st.stats["triangle_tests"]
        for part in st.instances:
            matrix = scene.matrix(part.instance)
            assert part.mesh == 0 and np.array_equal(part.matrix, matrix)
            inverse = np.linalg.inv(matrix.astype(np.float64))
            local = raylab.build(*scene.structure(0).mesh(), structure=structure).story(
                (inverse @ np.append(origins[i], 1.0))[:3].astype(np.float32),
                (inverse[:3, :3] @ directions[i]).astype(np.float32))
            if part.story.hit is None or local.hit is None:
                continue  # a closer instance may have cut this part's ray short
            assert part.story.hit["t"] <= local.hit["t"] or np.isclose(part.story.hit["t"], local.hit["t"])
    assert "hit_object" in seen and len(seen) >= 2  # the rays tell more than one case


@pytest.mark.parametrize("structure", [s for s, info in raylab.STRUCTURE_INFO.items() if info["uses_top_level"]])
def test_a_scene_story_shows_the_top_level_in_world_space(two_spheres, structure):
    scene = two_spheres(structure)
    st = scene.story([-3, 0, -10], [0, 0, 1])
    boxes = st.top_boxes
    assert len(boxes["lo"]) == st.stats["box_tests"] - sum(p.story.stats["box_tests"] for p in st.instances)
    assert boxes["hit"][0] and len(st.top_nodes) >= 1
    # The root of the top level holds both spheres: x from -4 to 5 in the world.
    assert boxes["lo"][0][0] == pytest.approx(-4, abs=1e-3) and boxes["hi"][0][0] == pytest.approx(5, abs=1e-3)
    assert [p.instance for p in st.instances] == [0] and st.hit["instance"] == 0
    missed = scene.story([0, 10, -10], [0, 0, 1])
    assert missed.status == "missed_root" and missed.instances == [] and not missed.top_boxes["hit"][0]


def test_a_scene_without_top_level_queries_every_instance():
    scene = raylab.Scene(structure="none")
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    m = scene.add_mesh(vertices, np.array([[0, 1, 2]], np.uint32))
    for x in (0, 5, 10):
        scene.add_instance(m, translate(x))
    scene.commit()
    st = scene.story([0.25, 0.25, 1], [0, 0, -1])
    assert [p.instance for p in st.instances] == [0, 1, 2] and len(st.top_boxes["lo"]) == 0
    assert st.status == "hit_object" and st.hit["instance"] == 0
    assert [p.story.status for p in st.instances] == ["hit_object", "missed_triangles", "missed_triangles"]


def test_scene_structures_and_cleared_instances(two_spheres, sphere):
    scene = two_spheres("octree")
    s = scene.structure(0)
    assert s.structure == "octree" and s.triangle_count == len(sphere[1])
    assert len(s.boxes()["lo"]) > 1
    scene.clear_instances()
    scene.add_instance(0, translate(0, 20))
    scene.commit()
    assert scene.instance_count == 1
    assert scene.structure(0).native is not None and scene.story([0, 20, -10], [0, 0, 1]).hit["instance"] == 0
    with pytest.raises(ValueError, match="unknown mesh id 3"):
        scene.structure(3)
    with pytest.raises(ValueError, match="unknown instance id 1"):
        scene.matrix(1)
