"""raylab.Scene from several Python threads (every binding releases the GIL): one thread changes and
commits while others intersect, test occlusion and render. Nothing crashes, and every answer comes
from one committed state whole: the old one or the new one, never a mix and never freed memory.
The two states of each test are far apart, so each answer tells which state it came from."""
import subprocess
import sys
import threading

import numpy as np
import pytest

import raylab

ADDITIONS = 200  # instances added one commit at a time


def translate(x, y=0.0, z=0.0, scale=1.0):
    m = np.diag([scale, scale, scale, 1.0])
    m[:3, 3] = (x, y, z)
    return m


def world(vertices, matrix):
    return (np.c_[vertices, np.ones(len(vertices))] @ matrix.T)[:, :3].astype(np.float32)


def rays_at(centres, offsets, copies=300):
    """Rays along +z from z = -10 through each centre shifted by each (dx, dy) offset, repeated so
    that a query spends long enough in native code (GIL released) for commits to overlap it."""
    origins = np.array([[cx + dx, cy + dy, -10.0] for cx, cy in centres for dx, dy in offsets], np.float32)
    return np.tile(origins, (copies, 1)), np.array([0, 0, 1], np.float32)


# Well inside the silhouette of a sphere of radius 0.5, so that no ray grazes a state's spheres.
NEAR_AXIS = [(dx, dy) for dx in (-0.25, 0.0, 0.25) for dy in (-0.2, 0.1, 0.3)]


def brute_force(meshes, origins, directions):
    """The closest hits over world-space meshes, each brute-forced: (hit, t, instance)."""
    t = np.full(len(origins), np.inf, np.float32)
    instance = np.full(len(origins), -1)
    for k, (vertices, triangles) in enumerate(meshes):
        h = raylab.build(vertices, triangles, structure="none").intersect(origins, directions)
        nearer = h.hit & (h.t < t)
        t[nearer], instance[nearer] = h.t[nearer], k
    return instance >= 0, t, instance


def same_hits(h, expected):
    hit, t, instance = expected
    return (np.array_equal(h.hit, hit) and np.array_equal(h.instance, instance)
            and np.allclose(h.t[hit], t[hit], rtol=1e-5))


def hammer(change, queries, rounds=10, most_changes=None):
    """Runs every query `rounds` times in each of two threads while one more thread runs change(k)
    for k = 0, 1, ... until they are done (or `most_changes` ran); raises the first error of any
    thread; returns the number of changes."""
    readers_done = threading.Event()
    errors, changes = [], []

    def writer():
        k = 0
        try:
            while not readers_done.is_set() and (most_changes is None or k < most_changes):
                change(k)
                k += 1
        except BaseException as e:  # noqa: BLE001 - raised in the test's thread
            errors.append(e)
        changes.append(k)

    def reader():
        try:
            for _ in range(rounds):
                for query in queries:
                    query()
        except BaseException as e:  # noqa: BLE001
            errors.append(e)

    writing = threading.Thread(target=writer)
    readers = [threading.Thread(target=reader) for _ in range(2)]
    for thread in [writing, *readers]:
        thread.start()
    for thread in readers:
        thread.join()
    readers_done.set()
    writing.join()
    if errors:
        raise errors[0]
    return changes[0]


def view():
    """A small orthographic view up +z at the origin, lit from behind the camera."""
    camera = dict(type="ORTHO", matrix_world=translate(0, 0, -10) @ np.diag([1.0, -1.0, -1.0, 1.0]),
                  ortho_scale=3.0, resolution_x=16, resolution_y=16, resolution_percentage=100,
                  clip_start=0.001, clip_end=100.0)
    lights = [dict(type="SUN", color=(1.0, 1.0, 1.0), energy=3.0, matrix_world=np.diag([1.0, -1.0, -1.0, 1.0]))]
    return camera, lights, [dict(diffuse=(0.8, 0.8, 0.8))]


def render_of(scene):
    r = raylab.render(scene, *view(), dict(super_sampling=1, shadows=True))
    return r.instance, r.distance


def one_of(got, references):
    return any(all(np.array_equal(g, r) for g, r in zip(got, ref)) for ref in references)


def queries_of(scene, states, origins, directions):
    """intersect and occluded, each failing unless its answer is one state's brute-force answer."""
    def intersect():
        h = scene.intersect(origins, directions)
        assert any(same_hits(h, e) for e in states.values()), "a mix of two states or garbage"

    def occluded():
        hit = scene.occluded(origins, directions).hit
        assert any(np.array_equal(hit, e[0]) for e in states.values()), "a mix of two states or garbage"

    return [intersect, occluded]


def test_moving_an_instance_while_others_query(sphere):
    vertices, triangles = sphere
    place = {"old": translate(0), "new": translate(100)}  # instance 0, far from where it was
    still = translate(3, scale=0.5)                        # instance 1 never moves
    scene = raylab.Scene()
    m = scene.add_mesh(vertices, triangles)
    scene.add_instance(m, place["old"])
    scene.add_instance(m, still)
    origins, directions = rays_at([(0, 0), (100, 0), (3, 0)], NEAR_AXIS)
    states = {name: brute_force([(world(vertices, p), triangles), (world(vertices, still), triangles)],
                                origins, directions) for name, p in place.items()}
    renders = {}
    for name in ("new", "old"):
        scene.set_transform(0, place[name])
        scene.commit()
        assert same_hits(scene.intersect(origins, directions), states[name])
        renders[name] = render_of(scene)
    assert not same_hits(scene.intersect(origins, directions), states["new"])
    assert (renders["old"][0] == 0).any() and not (renders["new"][0] == 0).any()

    def change(k):
        scene.set_transform(0, place["new" if k % 2 == 0 else "old"])
        scene.commit()

    def render():
        assert one_of(render_of(scene), renders.values()), "a render that mixed two states"

    assert hammer(change, [*queries_of(scene, states, origins, directions), render]) > 0


def test_replacing_a_mesh_while_others_query(sphere):
    vertices, triangles = sphere
    shapes = {"old": vertices, "new": vertices * 0.5}  # t along the axis: 9 against 9.5
    scene = raylab.Scene()
    m = scene.add_mesh(vertices, triangles)
    other = scene.add_mesh(vertices, triangles)
    scene.add_instance(m, np.eye(4))
    scene.add_instance(other, translate(3, scale=0.5))
    # Some rays hit the old sphere only (at 0.7 from the axis), some both.
    origins, directions = rays_at([(0, 0), (3, 0)], NEAR_AXIS + [(0.7, 0.0), (0.0, -0.7)])
    states = {name: brute_force([(v, triangles), (world(vertices, translate(3, scale=0.5)), triangles)],
                                origins, directions) for name, v in shapes.items()}
    renders = {}
    for name in ("new", "old"):
        scene.replace_mesh(m, shapes[name], triangles)
        scene.commit()
        assert same_hits(scene.intersect(origins, directions), states[name])
        renders[name] = render_of(scene)
    assert not same_hits(scene.intersect(origins, directions), states["new"])

    def change(k):
        scene.replace_mesh(m, shapes["new" if k % 2 == 0 else "old"], triangles)
        scene.commit()

    def render():
        assert one_of(render_of(scene), renders.values()), "a render that mixed two states"

    assert hammer(change, [*queries_of(scene, states, origins, directions), render]) > 0


def test_adding_instances_while_others_query(sphere):
    vertices, triangles = sphere
    scene = raylab.Scene()
    m = scene.add_mesh(vertices, triangles)
    scene.add_instance(m, np.eye(4))
    scene.commit()
    places = [translate(10.0 * (k + 1)) for k in range(ADDITIONS)]
    centres = [(10.0 * k, 0) for k in range(ADDITIONS + 1)]  # of instance k
    origins, directions = rays_at(centres, [(0.1, -0.2)], copies=20)
    place_of_ray = np.tile(np.arange(len(centres)), 20)
    # Places are 10 apart: each ray meets its own place alone, so each is brute-forced on its rays.
    every = np.zeros(len(origins), bool), np.full(len(origins), np.inf, np.float32), np.full(len(origins), -1)
    for k, place in enumerate([np.eye(4)] + places):
        mine = place_of_ray == k
        hit, t, _ = brute_force([(world(vertices, place), triangles)], origins[mine], directions)
        every[0][mine], every[1][mine], every[2][mine] = hit, t, np.where(hit, k, -1)
    assert every[0].all()

    def state(n):
        """The answer of the scene with instances 0 to n - 1."""
        hit, t, instance = (a.copy() for a in every)
        gone = place_of_ray >= n
        hit[gone], t[gone], instance[gone] = False, np.inf, -1
        return hit, t, instance

    def change(k):
        assert scene.add_instance(m, places[k]) == k + 1
        scene.commit()

    def intersect():
        h = scene.intersect(origins, directions)
        assert same_hits(h, state(h.instance.max() + 1)), "not the first n instances of one committed state"

    def occluded():
        hit = scene.occluded(origins, directions).hit
        assert np.array_equal(hit, state(hit.sum() // 20)[0]), "not the first n instances of one committed state"

    assert hammer(change, [intersect, occluded], most_changes=ADDITIONS) > 0
    assert same_hits(scene.intersect(origins, directions), state(scene.instance_count))


def test_a_thread_that_changed_the_scene_must_commit_but_others_see_the_last_commit(sphere):
    vertices, triangles = sphere
    scene = raylab.Scene()
    scene.add_instance(scene.add_mesh(vertices, triangles), np.eye(4))
    scene.commit()
    scene.set_transform(0, translate(100))  # not committed
    origins, directions = rays_at([(0, 0)], [(0.0, 0.0)], copies=1)
    with pytest.raises(RuntimeError, match="commit"):
        scene.intersect(origins, directions)
    seen = []
    other = threading.Thread(target=lambda: seen.append(scene.intersect(origins, directions).hit[0]))
    other.start()
    other.join()
    assert seen == [True]  # the committed state: the sphere still at the origin
    scene.commit()
    assert not scene.intersect(origins, directions).hit[0]


def test_a_new_thread_never_inherits_an_ended_threads_uncommitted_change(sphere):
    # A thread changes the scene and ends without commit(); the system recycles thread ids, and a new
    # thread given the ended one's id had its queries refused as if it had made the change itself.
    vertices, triangles = sphere
    scene = raylab.Scene()
    scene.add_instance(scene.add_mesh(vertices, triangles), np.eye(4))
    scene.commit()
    origins, directions = rays_at([(0, 0)], [(0.0, 0.0)], copies=1)
    refused, hits = [], []

    def query():
        try:
            hits.append(bool(scene.intersect(origins, directions).hit[0]))
        except RuntimeError as e:
            refused.append(str(e))

    for k in range(50):
        changer = threading.Thread(target=lambda k=k: scene.set_transform(0, translate(100 + k)))
        changer.start()
        changer.join()
        reader = threading.Thread(target=query)  # often gets the ended changer's id
        reader.start()
        reader.join()
    assert refused == []
    assert hits == [True] * 50  # the committed state: the sphere still at the origin


# Far more threads than any machine has: TBB terminated the process for more than 65536.
HUGE_THREADS = (65537, 70000, 100000, 2**31 - 1)

CALLS_WITH_HUGE_THREADS = r"""
import sys
import numpy as np
sys.path.insert(0, sys.argv[1])
import raylab
vertices, triangles = raylab.load_mesh(sys.argv[2])
structure = raylab.build(vertices, triangles, "bvh")
scene = raylab.Scene()
scene.add_instance(scene.add_mesh(vertices, triangles), np.eye(4))
scene.commit()
rng = np.random.default_rng(7)
origins = rng.uniform(-2, 2, (500, 3)).astype(np.float32)
directions = (-origins).astype(np.float32)
camera = dict(type="PERSP", matrix_world=np.eye(4) + np.diag([0, 0, 0, 0]), lens=30.0, resolution_x=16,
              resolution_y=12, resolution_percentage=100, clip_start=0.001, clip_end=100.0)
camera["matrix_world"][2, 3] = 4.0
def answers(threads):
    h = structure.intersect(origins, directions, threads=threads)
    s = scene.intersect(origins, directions, threads=threads)
    image = raylab.render(scene, camera, [], [{}], {"threads": threads}).image
    return [h.t, h.triangle, structure.occluded(origins, directions, threads=threads).hit,
            structure.statuses(origins, directions, threads=threads).status, s.t, s.instance, image]
one = answers(1)
for threads in map(int, sys.argv[3:]):
    assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(answers(threads), one)), threads
print("same answers")
"""


def test_more_threads_than_the_machine_has_trace_as_its_cores_do(tmp_path):
    # In a subprocess: the failure was a crash of the interpreter.
    from conftest import ADDON, MESH_DIR
    out = subprocess.run([sys.executable, "-c", CALLS_WITH_HUGE_THREADS, str(ADDON), str(MESH_DIR / "sphere.obj"),
                          *map(str, HUGE_THREADS)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "same answers"
