"""The experiments measured through raylab's Python API: the VRT thesis's render experiment with image
error against a super-sampled reference, rays leaking out of closed meshes (Möller–Trumbore against
the watertight test) and false self-hits of shadow rays against scene scale."""
import math
import os
import statistics
import time

import numpy as np

import raylab

from . import MESH_DIR, log
from .run import run_lookup, run_native

# The VRT thesis, section 6.1, Tables 1-4: goat head in front of the camera, render seconds (average
# of 3 trials) and ray-triangle tests. Its octree never accelerated anything (Unity's raycast hid
# the triangles), so its octree counts are what the octree "would" test.
THESIS = {
    "render_seconds": {"none": [0.1803, 0.5674, 1.2525], "aabb": [0.1480, 0.4708, 0.9915],
                       "octree": [0.2784, 0.8902, 1.9080]},
    "triangle_tests": {"none": [116_960_000, 467_840_000, 1_052_630_000],
                       "aabb": [22_994_336, 92_273_399, 207_390_548],
                       "octree": [1_173_277, 4_700_384, 10_557_042]},
}


# ---------------------------------------------------------------- the VRT thesis experiment

def look_at(eye, target, up=(0.0, 0.0, 1.0)):
    """Camera-to-world matrix of a Blender camera (looking down its local -Z, +Y up) at `eye`."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    forward = target - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    cam_up = np.cross(right, forward)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, cam_up, -forward, eye
    return m


def thesis_setup(V, width, height):
    """The goat head right in front of the camera (the thesis's Figure 22), a point light above the
    camera and one diffuse material."""
    lo, hi = V.min(0).astype(float), V.max(0).astype(float)
    center, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    # Blender's default lens: 50 mm on a 36 mm sensor, about 39.6 degrees across the wider side.
    half_fov = math.atan(0.5 * 36.0 / 50.0 * min(1.0, height / width))
    eye = center + np.array([0.0, -1.0, 0.25]) / np.linalg.norm([0.0, -1.0, 0.25]) * radius / math.sin(half_fov)
    camera = dict(type="PERSP", matrix_world=look_at(eye, center), lens=50.0, sensor_width=36.0,
                  sensor_height=24.0, sensor_fit="AUTO", clip_start=0.01, clip_end=1e4,
                  resolution_x=width, resolution_y=height, resolution_percentage=100)
    light_matrix = np.eye(4)
    light_matrix[:3, 3] = eye + np.array([radius, 0.0, 2 * radius])
    lights = [dict(type="POINT", color=(1.0, 1.0, 1.0), energy=2000.0 * radius ** 2, matrix_world=light_matrix,
                   radius=0.0, shadows=True)]
    materials = [dict(diffuse=(0.8, 0.7, 0.6), specular=0.3, shininess=32.0, ambient=0.05)]
    return camera, lights, materials


def built_structures():
    """The structures this build provides (while a structure is being written its build raises)."""
    triangle = (np.eye(3, dtype=np.float32), np.array([[0, 1, 2]], np.uint32))
    out = []
    for structure in raylab.STRUCTURES:
        try:
            raylab.build(*triangle, structure=structure)
            out.append(structure)
        except RuntimeError as error:
            log(f"{structure} is not available: {error}")
    return out


def render_once(V, T, structure, camera, lights, materials, **settings):
    scene = raylab.Scene(structure=structure, max_depth=6, leaf_size=8)
    scene.add_instance(scene.add_mesh(V, T), np.eye(4), material=0)
    scene.commit()
    base = dict(super_sampling=1, max_recursion=3, shadows=True, background=(0.05, 0.05, 0.05),
                ambient=(1.0, 1.0, 1.0), threads=0)
    return raylab.render(scene, camera, lights, materials, base | settings)


def run_thesis(config):
    """Render seconds (median of reps) and ray-triangle tests per structure and super-sampling,
    side by side with the thesis; the images feed the speed-against-accuracy chart."""
    cfg = config["thesis"]
    V, T = raylab.load_mesh(MESH_DIR / "goathead.obj")
    camera, lights, materials = thesis_setup(V, cfg["width"], cfg["height"])
    log("thesis experiment", "with raylab.render")
    rows, images = [], {}
    for structure in built_structures():
        for ss in cfg["super_sampling"]:
            reps = cfg["reps"] if ss <= len(THESIS["render_seconds"]["none"]) else 1  # the thesis's levels
            seconds, stats = [], None
            for _ in range(reps):
                res = render_once(V, T, structure, camera, lights, materials, super_sampling=ss)
                seconds.append(res.stats["render_seconds"])
                stats = {k: res.stats[k] for k in ("rays_primary", "rays_shadow", "rays_ignored", "box_tests",
                                                   "triangle_tests", "build_seconds")}
                images[(structure, ss)] = res.image
            rows.append(dict(structure=structure, super_sampling=ss, repetitions=reps,
                             render_seconds_median=statistics.median(seconds), render_seconds=seconds, **stats))
    result = {"mode": "render", "note": "raylab.render, Whitted shading with shadows, one point light",
              "width": cfg["width"], "height": cfg["height"], "mesh": "goathead.obj", "triangles": len(T),
              "rows": rows, "thesis": THESIS, "reference_super_sampling": cfg["reference_ss"]}
    if images:
        result["image_error"] = image_errors(images, reference_render(V, T, camera, lights, materials,
                                                                      cfg["reference_ss"]))
    return result


def reference_render(V, T, camera, lights, materials, samples):
    """The scene with samples x samples rays per pixel, traced with the BVH (every structure gives the
    same image; image_errors checks that at each level). The renderer super-samples up to 4x4, so the
    picture is rendered k times larger at samples/k and each k x k block averaged: the same regular
    grid of samples."""
    k = next(k for k in range(math.ceil(samples / 4), samples + 1) if samples % k == 0)
    big = dict(camera, resolution_x=camera["resolution_x"] * k, resolution_y=camera["resolution_y"] * k)
    image = render_once(V, T, "bvh", big, lights, materials, super_sampling=samples // k).image
    h, w = camera["resolution_y"], camera["resolution_x"]
    return image.reshape(h, k, w, k, image.shape[-1]).mean(axis=(1, 3))


def image_errors(images, reference):
    """RMSE and PSNR of every render against the reference render (colours clipped to [0, 1] as
    displayed), and the largest difference between structures at the same super-sampling: the
    structures must give the same image."""
    structures = sorted({s for s, _ in images})
    ref = np.clip(reference[..., :3], 0, 1)
    out = []
    for (structure, ss), img in sorted(images.items()):
        diff = np.clip(img[..., :3], 0, 1) - ref
        rmse = float(np.sqrt(np.mean(diff ** 2)))
        psnr = math.inf if rmse == 0 else 20 * math.log10(1.0 / rmse)
        across = max(float(np.abs(img - images[(other, ss)]).max()) for other in structures)
        out.append(dict(structure=structure, super_sampling=ss, rmse=rmse,
                        psnr_db=psnr if math.isfinite(psnr) else None, max_difference_to_other_structures=across))
    return out


def thesis_structures(thesis):
    """The structures of the thesis experiment's rows, in the order they were measured."""
    return list(dict.fromkeys(r["structure"] for r in thesis["rows"]))


# ---------------------------------------------------------------- leaks: Möller–Trumbore vs watertight

def crossings(structure, origins, direction):
    """How many times each ray from `origins` along `direction` crosses the surface."""
    count = np.zeros(len(origins), int)
    travelled = np.zeros(len(origins), np.float32)
    active = np.arange(len(origins))
    for _ in range(200):
        if not len(active):
            break
        # Each ray restarts from its last hit point, so one tmin serves every ray.
        h = structure.intersect(origins[active] + travelled[active, None] * direction, direction, tmin=1e-5)
        count[active[h.hit]] += 1
        travelled[active[h.hit]] += h.t[h.hit]
        active = active[h.hit]
    return count


def inside_points(structure, lo, hi, count, rng):
    """Random points inside a closed mesh: an odd number of crossings along each of three
    directions (one direction alone misjudges points whose ray grazes an edge)."""
    candidates = rng.uniform(lo, hi, size=(count * 4, 3)).astype(np.float32)
    inside = np.ones(len(candidates), bool)
    for direction in ([0.5773, 0.5774, 0.5775], [-0.31, 0.72, -0.62], [0.11, -0.45, 0.886]):
        inside &= crossings(structure, candidates, np.array(direction, np.float32)) % 2 == 1
    return candidates[inside][:count]


# The BVH's ways of testing a triangle the leak experiment compares: each triangle test in the exact
# contract, and each other contract (which takes the watertight setting).
LEAK_METHODS = ([(test, "exact") for test in raylab.TRIANGLE_TESTS]
                + [("watertight", contract) for contract in raylab.CONTRACTS if contract != "exact"])


def leak_method(row):
    """A leak row's method by one name: its triangle test in the exact contract, else its contract."""
    return row["triangle_test"] if row.get("contract", "exact") == "exact" else row["contract"]


def run_leaks(config, data_dir):
    """Rays from inside closed meshes towards vertices, edge midpoints and random directions: every
    one must hit. Counts the escapes and the throughput of each method (LEAK_METHODS) on the same rays."""
    cfg = config["leaks"]
    rng = np.random.default_rng(7)
    out = []
    for name in cfg["meshes"]:
        # The generated icosphere exists only as raylab_bench's export; shipped meshes load directly.
        if (data_dir / f"{name}.vertices.npy").exists():
            V, T = np.load(data_dir / f"{name}.vertices.npy"), np.load(data_dir / f"{name}.triangles.npy")
        else:
            V, T = raylab.load_mesh(MESH_DIR / f"{name}.obj")
        reference = raylab.build(V, T, structure="bvh")
        n = cfg["rays_per_kind"]
        origins = inside_points(reference, V.min(0), V.max(0), n, rng)
        if len(origins) == 0:
            continue
        origins = origins[rng.integers(0, len(origins), n)]
        edge = rng.integers(0, 3, n)
        tri = T[rng.integers(0, len(T), n)]
        targets = {"vertex": V[tri[np.arange(n), edge]],
                   "edge": 0.5 * (V[tri[np.arange(n), edge]] + V[tri[np.arange(n), (edge + 1) % 3]])}
        directions = {k: (p - origins) for k, p in targets.items()}
        directions["random"] = rng.normal(size=(n, 3)).astype(np.float32)
        for test, contract in LEAK_METHODS:
            s = raylab.build(V, T, structure="bvh", triangle_test=test, contract=contract)
            for kind, d in directions.items():
                seconds = []
                for _ in range(cfg["reps"]):
                    start = time.perf_counter()
                    h = s.intersect(origins, d)
                    seconds.append(time.perf_counter() - start)
                med = statistics.median(seconds)
                out.append(dict(mesh=name, triangles=len(T), triangle_test=test, contract=contract, rays=kind,
                                ray_count=n,
                                escaped=int((~h.hit).sum()), rays_per_second=n / med, seconds_median=med))
        log(f"leaks {name} done")
    return out


# ---------------------------------------------------------------- false self-hits against scale

def run_self_hits(config):
    """A convex sphere lit by a sun: nothing on it can shadow itself, so every pixel that comes out
    darker with shadows on than with shadows off is a false self-hit of a shadow ray. The scene is
    scaled and moved away from the origin by each scale (so coordinates grow with it) and rendered
    with fixed epsilons and with the robust integer-ulp offset."""
    cfg = config["self_hits"]
    V, T = raylab.load_mesh(MESH_DIR / "sphere.obj")
    methods = [("fixed 1e-4", dict(robust_offset=False, fixed_epsilon=1e-4)),
               ("fixed 1e-6", dict(robust_offset=False, fixed_epsilon=1e-6)),
               ("robust", dict(robust_offset=True))]
    sun = look_at((0.3, -1.0, 1.0), (0.0, 0.0, 0.0))
    lights = [dict(type="SUN", color=(1.0, 1.0, 1.0), energy=3.0, matrix_world=sun, shadows=True)]
    materials = [dict(diffuse=(0.8, 0.8, 0.8), specular=0.0, ambient=0.05)]
    rows = []
    for scale in cfg["scales"]:
        offset = np.array([3.0, 2.0, 1.0]) * scale
        place = np.diag([scale, scale, scale, 1.0])
        place[:3, 3] = offset
        eye = offset + np.array([0.0, -4.0, 1.0]) * scale
        camera = dict(type="PERSP", matrix_world=look_at(eye, offset), lens=50.0, sensor_width=36.0,
                      sensor_fit="AUTO", clip_start=1e-3 * scale, clip_end=1e3 * scale,
                      resolution_x=cfg["width"], resolution_y=cfg["height"], resolution_percentage=100)
        scene = raylab.Scene(structure="bvh")
        scene.add_instance(scene.add_mesh(V, T), place, material=0)
        scene.commit()
        base = dict(super_sampling=1, max_recursion=1, background=(0, 0, 0), ambient=(1, 1, 1))
        reference = raylab.render(scene, camera, lights, materials, base | dict(shadows=False))
        unshadowed, on_sphere = reference.image, reference.instance >= 0
        lit = on_sphere & (unshadowed[..., :3].sum(-1) > 3 * 0.05 * 0.8 + 1e-3)
        for method, settings in methods:
            res = raylab.render(scene, camera, lights, materials, base | dict(shadows=True) | settings)
            darker = (unshadowed[..., :3] - res.image[..., :3]).max(-1) > 1e-3
            rows.append(dict(scale=scale, method=method, lit_pixels=int(lit.sum()),
                             false_self_hits=int((darker & lit).sum()),
                             fraction=float((darker & lit).sum() / max(1, lit.sum()))))
        log(f"self-hits at scale {scale:g} done")
    return {"rows": rows, "mesh": "sphere.obj", "light": "sun"}


# ---------------------------------------------------------------- an animation: refit against rebuild

def _median_seconds(run, reps):
    seconds = []
    for _ in range(reps):
        start = time.perf_counter()
        run()
        seconds.append(time.perf_counter() - start)
    return statistics.median(seconds)


def run_animation(config):
    """A shipped mesh twisted and waved over the frames (raylab.animation.twist_wave). Each frame the
    BVH is rebuilt from scratch and, separately, refitted from the previous frame's refit (as an
    animation plays, starting from frame 0's build); both trace the same rays (a fixed camera framing
    the rest pose, and random rays) on one thread. Per frame: build and refit seconds (the core's own
    timers, medians of the repetitions), trace seconds after each, the SAH cost of both trees, and
    whether their hits agree (they must: a refit is exact)."""
    from raylab import animation, rays

    cfg = config["animation"]
    V, T = raylab.load_mesh(MESH_DIR / f"{cfg['mesh']}.obj")
    frames, reps = cfg["frames"], cfg["reps"]
    camera = rays.camera_rays(V, cfg["camera"])
    rng = np.random.default_rng(1)
    random = rays.random_rays(V, cfg["random_rays"], rng)
    origins, directions = np.concatenate([camera[0], random[0]]), np.concatenate([camera[1], random[1]])
    refitted = None
    rows = []
    for frame in range(frames):
        moved = animation.twist_wave(V, frame, frames)
        builds = [raylab.build(moved, T) for _ in range(reps)]
        rebuilt = builds[-1]
        if refitted is None:
            refitted = rebuilt  # frame 0: the animation starts from a build
            refit_seconds = statistics.median(b.build_seconds for b in builds)
        else:
            source = refitted
            refits = [source.refit(moved) for _ in range(reps)]
            refitted = refits[-1]
            refit_seconds = statistics.median(r.build_seconds for r in refits)
        hits = [s.intersect(origins, directions, threads=1) for s in (rebuilt, refitted)]
        same = all(np.array_equal(getattr(hits[0], f), getattr(hits[1], f)) for f in ("hit", "triangle", "t", "u", "v"))
        # Interleaved, so that the machine's drift falls on both alike.
        seconds = ([], [])
        for _ in range(reps):
            for s, out in zip((rebuilt, refitted), seconds):
                out.append(_median_seconds(lambda: s.intersect(origins, directions, threads=1), 1))
        rows.append(dict(frame=frame, rebuild_seconds=statistics.median(b.build_seconds for b in builds),
                         refit_seconds=refit_seconds, rebuilt_trace_seconds=statistics.median(seconds[0]),
                         refitted_trace_seconds=statistics.median(seconds[1]), rebuilt_sah_cost=rebuilt.sah_cost(),
                         refitted_sah_cost=refitted.sah_cost(), same_hits=same))
    log(f"animation of {cfg['mesh']} over {frames} frames done")
    later = rows[1:]  # frame 0 is a build for both
    median = lambda key: statistics.median(r[key] for r in later)  # noqa: E731
    summary = dict(
        rebuild_seconds_median=median("rebuild_seconds"), refit_seconds_median=median("refit_seconds"),
        refit_speedup_median=statistics.median(r["rebuild_seconds"] / r["refit_seconds"] for r in later),
        trace_ratio_median=statistics.median(r["refitted_trace_seconds"] / r["rebuilt_trace_seconds"] for r in later),
        trace_ratio_last=rows[-1]["refitted_trace_seconds"] / rows[-1]["rebuilt_trace_seconds"],
        sah_ratio_last=rows[-1]["refitted_sah_cost"] / rows[-1]["rebuilt_sah_cost"],
        all_hits_equal=all(r["same_hits"] for r in rows))
    return {"mesh": cfg["mesh"], "triangles": len(T), "frames": frames, "rays": len(origins),
            "animation": "raylab.animation.twist_wave", "rows": rows, "summary": summary}


def run_builders(config):
    """The BVH's builders side by side (raylab.BUILDERS) on each mesh: build seconds (the core's timer,
    median of the repetitions, on the threads the process may use), the SAH cost, and per ray the
    triangle tests and nodes visited (closest hit, counted) of camera rays and random rays, with the
    camera rays' one-thread trace seconds. Every builder's hits are checked against the default's."""
    from raylab import rays

    cfg = config["builders"]
    out = []
    for name in cfg["meshes"]:
        V, T = raylab.load_mesh(MESH_DIR / f"{name}.obj")
        sets = {"camera": rays.camera_rays(V, cfg["camera"]),
                "random": rays.random_rays(V, cfg["random_rays"], np.random.default_rng(2))}
        reference = None
        for builder in raylab.BUILDERS:
            builds = [raylab.build(V, T, builder=builder) for _ in range(cfg["reps"])]
            s = builds[-1]
            row = dict(mesh=name, triangles=len(T), builder=builder,
                       build_seconds=statistics.median(b.build_seconds for b in builds), sah_cost=s.sah_cost(),
                       nodes=s.tree()["node_count"], memory_bytes=s.memory_bytes)
            for kind, (origins, directions) in sets.items():
                hits = s.intersect(origins, directions, count=True, threads=1)
                n = hits.stats["rays"]
                row[f"{kind}_triangle_tests_per_ray"] = hits.stats["triangle_tests"] / n
                row[f"{kind}_nodes_per_ray"] = hits.stats["nodes_visited"] / n
                if reference is None or kind not in reference:
                    reference = (reference or {}) | {kind: hits}
                row[f"{kind}_same_hits"] = bool(np.array_equal(hits.triangle, reference[kind].triangle) and
                                                np.array_equal(hits.t, reference[kind].t))
            origins, directions = sets["camera"]
            row["camera_trace_seconds"] = _median_seconds(lambda: s.intersect(origins, directions, threads=1),
                                                          cfg["reps"])
            out.append(row)
        log(f"builders on {name} done")
    return {"rows": out, "camera": cfg["camera"], "random_rays": cfg["random_rays"], "reps": cfg["reps"]}


# ---------------------------------------------------------------- the user's path: `import raylab`

# The queries timed through the API, each with the query of raylab_bench it answers like.
API_QUERIES = (("intersect", "closest"), ("occluded", "any"))
# raylab_bench's ray sets the API traces (it exports every ray of them: <mesh>.trace_<set>.npy), and the
# rays that all miss the root box: the door's fixed cost per ray.
API_SETS = ("camera", "camera_sky", "random")
MISSING = "missing_root"


class OneCore:
    """This process pinned to its first allowed core while the block runs (as raylab_bench pins its
    one-thread runs), its affinity restored after."""

    def __enter__(self):
        self.saved = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
        self.core = min(self.saved) if self.saved else None
        if self.saved:
            os.sched_setaffinity(0, {self.core})
        return self

    def __exit__(self, *_):
        if self.saved:
            os.sched_setaffinity(0, self.saved)


def api_rays(data_dir, name):
    """raylab_bench's exported rays of the API's sets as C-contiguous float32 (N,3) origins and
    directions (what a caller hands the API), and as many rays beyond the mesh's box looking away."""
    sets = {}
    for ray_set in API_SETS:
        rows = np.load(data_dir / f"{name}.trace_{ray_set}.npy")
        sets[ray_set] = (np.ascontiguousarray(rows[:, 0:3]), np.ascontiguousarray(rows[:, 4:7]))
    V = np.load(data_dir / f"{name}.vertices.npy")
    n = len(sets["camera"][0])
    lo, hi = V.min(axis=0), V.max(axis=0)
    sets[MISSING] = (np.tile((hi + (hi - lo)).astype(np.float32), (n, 1)), np.tile(np.float32([0, 0, 1]), (n, 1)))
    return sets


def run_api(config, data_dir, name, native_mesh):
    """The user's path on one mesh of raylab_bench's run: `raylab.build(...)` and a `raylab.Scene` with one
    instance, in each contract, tracing raylab_bench's own rays (every ray of the camera framing the
    mesh, the camera with sky around it and the random set) with `intersect` and `occluded`, numpy in
    and numpy out, threads=1, this process pinned to one core, the calls' rounds interleaved, medians.
    Rays/s of each, and its ratio to Embree's single rays (rtcIntersect1 / rtcOccluded1), Embree's
    packets (rtcIntersect8 / rtcOccluded8) and raylab's C++ core (raylab_bench's bvh, same contract) on
    the same set and query, one thread, from the raylab_bench run just before on this mesh. Rays that
    all miss the root box give the door's fixed cost per ray (ns)."""
    cfg = config["api"]
    V = np.load(data_dir / f"{name}.vertices.npy")
    T = np.load(data_dir / f"{name}.triangles.npy")
    sets = api_rays(data_dir, name)
    targets = {}
    for contract in raylab.CONTRACTS:
        targets[("Structure", contract)] = raylab.build(V, T, contract=contract)
        scene = raylab.Scene(contract=contract)
        scene.add_instance(scene.add_mesh(V, T), np.eye(4))
        scene.commit()
        targets[("Scene", contract)] = scene
    calls = {(target, contract, ray_set, query): (getattr(obj, query), sets[ray_set])
             for (target, contract), obj in targets.items() for ray_set in sets for query, _ in API_QUERIES}
    hit_share = {ray_set: float(targets[("Structure", "exact")].intersect(*rays).hit.mean())
                 for ray_set, rays in sets.items()}
    seconds = {key: [] for key in calls}
    # The clock raylab_bench used: its process's CPU time (--cpu-time: the time other processes held the
    # core left out, on both sides of the ratio) or the wall clock.
    clock = time.process_time if native_mesh.get("clock") == "cpu" else time.perf_counter
    with OneCore() as pin:
        for call, (origins, directions) in calls.values():  # warm-up
            call(origins, directions, threads=1)
        for _ in range(cfg["reps"]):  # interleaved: the machine's drift falls on every call alike
            for key, (call, (origins, directions)) in calls.items():
                start = clock()
                call(origins, directions, threads=1)
                seconds[key].append(clock() - start)
    tracers = {t["name"]: t for t in native_mesh["tracers"]}
    reference = {"embree_1": tracers.get("embree_medium"), "embree_8": tracers.get("embree_packets")}
    rows = []
    for (target, contract, ray_set, query), times in seconds.items():
        n = len(calls[(target, contract, ray_set, query)][1][0])
        median = statistics.median(times)
        row = dict(mesh=name, triangles=len(T), target=target, contract=contract, rays=ray_set, query=query,
                   ray_count=n, hit_share=hit_share[ray_set], seconds_median=median, rays_per_second=n / median,
                   ns_per_ray=1e9 * median / n)
        if ray_set != MISSING:
            native_query = dict(API_QUERIES)[query]
            reference["core"] = tracers.get("bvh" if contract == "exact" else f"bvh_{contract}")
            for key, tracer in reference.items():
                other = run_lookup(tracer, ray_set, native_query, 1) if tracer else None
                row[f"{key}_rays_per_second"] = other["rays_per_second"] if other else None
                row[f"ratio_to_{key}"] = row["rays_per_second"] / other["rays_per_second"] if other else None
        rows.append(row)
    log(f"the user's path on {name} done")
    return {"rows": rows, "reps": cfg["reps"], "pinned_core": pin.core,
            "clock": "process CPU time" if clock is time.process_time else "wall clock"}


def api_result(native, api):
    """The user's path of every mesh with what the goal table reads from raylab_bench beside it: the exact
    BVH's wrong answers and the unexplained disagreements with Embree."""
    return {"meshes": api, "exactness": {name: exactness_summary(mesh) for name, mesh in native.items()}}


def exactness_summary(mesh):
    tracers = {t["name"]: t for t in mesh["tracers"]}
    exact = tracers.get("bvh") or {}
    wrong = sum(s["wrong"] for s in (exact.get("exactness") or {}).values())
    rays = sum(s["rays"] for s in (exact.get("exactness") or {}).values())
    unexplained = sum(counts.get("unexplained", 0)
                      for t in mesh["tracers"] if t["kind"] == "raylab" and not t["error"]
                      for per in t["tracing"]["per_ray_set"].values()
                      for counts in per["agreement_with_embree"].values())
    packets = tracers.get("embree_packets") or {}
    differ = sum(a["rays"] - a["closest"]["same"]
                 for per in packets.get("tracing", {}).get("per_ray_set", {}).values()
                 for a in [per["agreement_with_single_rays"]])
    return {"exact_wrong": wrong, "exact_judged": rays, "unexplained": unexplained,
            "embree_packets_differ_from_single": differ}


def only_api(config, binary, data):
    """raylab_bench with the API's "native" arguments (the BVH in both contracts, Embree's single rays and
    packets, one thread) and, right after it on each mesh, the user's path on its rays."""
    api = {}
    native = run_native(config, binary, data, arguments=config["api"]["native"],
                        after_each=lambda name, mesh: api.update({name: run_api(config, data, name, mesh)}))
    return api_result(native, api)


# ---------------------------------------------------------------- F12's renderer against a baseline's

def run_render(config, baseline):
    """raylab.render (what F12 runs) on one thread against the renderer of another checkout (`baseline`,
    whose add-on holds its built module: last turn's main, say): each render in its own process
    (tools/bench/render_worker.py, pinned to one core), the two checkouts alternating and which goes
    first swapped every round, medians over every round's renders. Speed-up: the baseline's median
    seconds over this checkout's (above 1: this one is faster), by the renderer's own timer and by the
    process's CPU time."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    from . import ROOT

    cfg = config["render"]
    addons = {"baseline": str(Path(baseline).resolve() / "addon"), "this": str(ROOT / "addon")}
    times = {}
    for round_ in range(cfg["rounds"]):
        order = ["baseline", "this"] if round_ % 2 == 0 else ["this", "baseline"]
        for name, width, height, levels, renders in cfg["scenes"]:
            for which in order:
                done = subprocess.run(
                    [sys.executable, "-m", "tools.bench.render_worker", "--scene", name, "--size",
                     f"{width}x{height}", "--super-sampling", ",".join(map(str, levels)), "--renders",
                     str(renders)], cwd=ROOT, env=os.environ | {"RAYLAB_BENCH_ADDON": addons[which]},
                    check=True, capture_output=True, text=True)
                out = json.loads(done.stdout)
                for ss, r in out["renders"].items():
                    entry = times.setdefault((name, int(ss)), {"triangles": out["triangles"], "width": width,
                                                               "height": height})
                    for clock in ("render_seconds", "cpu_seconds"):
                        entry.setdefault(f"{which}_{clock}", []).extend(r[clock])
        log(f"render round {round_ + 1} of {cfg['rounds']} done")
    rows = []
    for (name, ss), e in times.items():
        row = dict(scene=name, super_sampling=ss, triangles=e["triangles"], width=e["width"], height=e["height"])
        for clock in ("render_seconds", "cpu_seconds"):
            row[f"baseline_{clock}_median"] = statistics.median(e[f"baseline_{clock}"])
            row[f"this_{clock}_median"] = statistics.median(e[f"this_{clock}"])
            row[f"speedup_{clock}"] = row[f"baseline_{clock}_median"] / row[f"this_{clock}_median"]
        rows.append(row)
    return {"rows": rows, "baseline": str(Path(baseline).resolve()), "rounds": cfg["rounds"],
            "renders_per_process": {name: renders for name, *_, renders in cfg["scenes"]}}
