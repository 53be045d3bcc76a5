"""./raylab bench: measure raylab's structures against Embree (3 on Debian 12, 4 on Debian 13) and
Blender's BVHTree, reproduce the VRT thesis's render experiment (its section 6.1), and chart speed against accuracy.

    /usr/bin/python3 tools/bench.py [--quick] [--out out/bench] [--build-dir build]

Everything is measured in this one run, on this machine, as medians of repetitions; comparisons are
ratios on the same rays (the machines are shared and noisy: absolute times drift, ratios less).
Writes <out>/results.json, <out>/results.md and <out>/bench_*.png; the raw per-mesh files of
raylab_bench and Blender stay in <out>/data/.
"""
import argparse
import json
import math
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "addon"))

import numpy as np  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import raylab  # noqa: E402

MESH_DIR = ROOT / "addon" / "raylab" / "meshes"
BLENDER = ["blender", "-b", "--factory-startup", "--python-exit-code", "1"]

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

FULL = {
    "meshes": [("goathead", "goathead.obj"), ("bunny_hr", "bunny_hr.obj"), ("dragon", "dragon.obj"),
               ("icosphere", "icosphere:8")],
    "native": ["--camera", "512x384", "--random-rays", "100000", "--export-rays", "20000", "--reps", "3",
               "--build-reps", "3", "--rep-seconds", "0.08", "--threads", "1,2", "--embree", "medium,high"],
    "blender_reps": 3,
    "thesis": {"width": 160, "height": 120, "super_sampling": [1, 2, 3, 4], "reps": 3, "reference_ss": 8},
    "leaks": {"meshes": ["goathead", "armadillo", "icosphere"], "rays_per_kind": 20000, "reps": 3},
    "self_hits": {"scales": [1e-3, 1e-2, 1e-1, 1, 1e1, 1e2, 1e3, 1e4, 1e5], "width": 96, "height": 72},
}
QUICK = {
    "meshes": [("goathead", "goathead.obj")],
    "native": ["--camera", "48x36", "--random-rays", "1500", "--export-rays", "300", "--reps", "1",
               "--build-reps", "1", "--rep-seconds", "0.01", "--threads", "1,2", "--embree", "medium"],
    "blender_reps": 1,
    "thesis": {"width": 32, "height": 24, "super_sampling": [1, 2], "reps": 1, "reference_ss": 4},
    "leaks": {"meshes": ["goathead"], "rays_per_kind": 1000, "reps": 1},
    "self_hits": {"scales": [1e-3, 1, 1e5], "width": 24, "height": 18},
}
DISAGREEMENT_KINDS = ("same", "rounding", "shared_edge_vertex", "coincident_faces", "edge_ray", "edge_ray_passed",
                      "grazing", "unexplained")


def log(*args):
    print("bench:", *args, flush=True)


# ---------------------------------------------------------------- raylab_bench and Embree

def bench_binary(build_dir):
    path = Path(build_dir) / "raylab_bench"
    if not path.exists():
        sys.exit(f"bench: {path} not found; build with embree (libembree-dev) first: ./raylab setup")
    return path


def run_native(config, binary, data_dir):
    results = {}
    for name, source in config["meshes"]:
        mesh = source if source.startswith("icosphere:") else str(MESH_DIR / source)
        log(f"raylab_bench {name}")
        subprocess.run([str(binary), "--mesh", mesh, "--name", name, "--out", str(data_dir), *config["native"]],
                       check=True)
        results[name] = json.loads((data_dir / f"{name}.json").read_text())
        add_ratios(results[name])
    return results


def run_lookup(tracer, ray_set, query, threads):
    for run in tracer.get("tracing", {}).get("runs", []):
        if (run["rays"], run["query"], run["threads"]) == (ray_set, query, threads):
            return run
    return None


def add_ratios(mesh):
    """raylab / Embree (medium) for every raylab structure: rays/s ratios (< 1: slower than Embree),
    build-time and memory ratios (> 1: slower / bigger)."""
    tracers = {t["name"]: t for t in mesh["tracers"]}
    embree = tracers["embree_medium"]
    for t in mesh["tracers"]:
        if t["kind"] != "raylab" or t["error"]:
            continue
        ratios = {}
        for run in t["tracing"]["runs"]:
            ref = run_lookup(embree, run["rays"], run["query"], run["threads"])
            key = f'{run["rays"]}_{run["query"]}_{run["threads"]}t_rays_per_second'
            ratios[key] = run["rays_per_second"] / ref["rays_per_second"]
        for threads, build in t["build"].items():
            ratios[f"build_{threads}t_seconds"] = build["seconds_median"] / embree["build"][threads]["seconds_median"]
        ratios["memory_bytes"] = t["memory_bytes"] / max(1, embree["memory_bytes"])
        t["ratios_to_embree_medium"] = ratios


# ---------------------------------------------------------------- Blender's BVHTree

def on_edge(V, T, triangles, points, origins):
    """Whether each hit point lies on its triangle's edge, as native/bench/hit_comparison.cpp decides:
    smallest barycentric below 1e-5, or distance to the nearest edge below 1e-6 of the magnitude of
    the corners and the ray origin (double precision; Blender reports points, not barycentrics)."""
    p = [V[T[triangles, c]].astype(np.float64) for c in range(3)]
    e1, e2, d = p[1] - p[0], p[2] - p[0], points - p[0]
    d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    d1, d2 = (d * e1).sum(1), (d * e2).sum(1)
    denom = d11 * d22 - d12 * d12
    with np.errstate(invalid="ignore", divide="ignore"):
        u = (d22 * d1 - d12 * d2) / denom
        v = (d11 * d2 - d12 * d1) / denom
        b = np.stack([1.0 - u - v, u, v], axis=1)
        twice_area = np.linalg.norm(np.cross(e1, e2), axis=1)
        # b[i] times the height over the edge opposite vertex i is the distance to that edge
        opposite = np.stack([np.linalg.norm(p[(i + 2) % 3] - p[(i + 1) % 3], axis=1) for i in range(3)], axis=1)
        distance = b * (twice_area[:, None] / opposite)
    scale = np.maximum(np.max(np.abs(np.stack(p, axis=1)), axis=(1, 2)), np.abs(origins).max(axis=1))
    # a degenerate triangle is all edge, as in the C++
    return (twice_area == 0) | (b.min(axis=1) < 1e-5) | (distance.min(axis=1) < 1e-6 * scale)


def classify(V, T, origins, directions, a_t, a_tri, b_t, b_tri):
    """Counts per disagreement kind between two tracers' closest hits: the classes of
    native/bench/hit_comparison.cpp, from t and triangle alone."""
    a_hit, b_hit = a_tri >= 0, b_tri >= 0
    o, d = origins.astype(np.float64), directions.astype(np.float64)
    with np.errstate(invalid="ignore"):
        pa = o + np.where(a_hit, a_t, 0.0)[:, None] * d
        pb = o + np.where(b_hit, b_t, 0.0)[:, None] * d
    a_edge, b_edge = np.zeros(len(a_t), bool), np.zeros(len(a_t), bool)
    a_edge[a_hit] = on_edge(V, T, a_tri[a_hit], pa[a_hit], o[a_hit])
    b_edge[b_hit] = on_edge(V, T, b_tri[b_hit], pb[b_hit], o[b_hit])
    scale = np.max(np.abs(np.concatenate([o, pa, pb], axis=1)), axis=1)
    same_point = np.linalg.norm(pa - pb, axis=1) <= 1e-6 * scale
    # the same triangle: the hit points' distance along its normal (a slide along the face is rounding
    # that a short t or a grazing ray magnifies)
    corners = V[T[np.where(a_hit, a_tri, 0)]].astype(np.float64)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        off_plane = np.abs((pa - pb) * normal).sum(1) / np.linalg.norm(normal, axis=1)
    plane_scale = np.maximum(np.abs(corners).max(axis=(1, 2)), np.abs(o).max(axis=1))
    same_plane_point = off_plane <= 1e-6 * plane_scale
    kind = np.full(len(a_t), "unexplained", dtype=object)
    kind[~a_hit & ~b_hit] = "same"
    one = a_hit != b_hit
    kind[one & a_hit & a_edge] = "edge_ray"          # the first tracer hits an edge the second passes
    kind[one & b_hit & b_edge] = "edge_ray_passed"   # the reverse
    both = a_hit & b_hit
    with np.errstate(invalid="ignore"):
        dt = np.abs(a_t - b_t) / np.maximum(np.maximum(np.abs(a_t), np.abs(b_t)), 1e-30)
    same_tri = both & (a_tri == b_tri)
    unit = d / np.linalg.norm(d, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        cosine = np.abs((unit * normal).sum(1)) / np.linalg.norm(normal, axis=1)
    kind[same_tri & (dt > 1e-5) & ~same_plane_point & ~(cosine >= 1e-3)] = "grazing"
    kind[same_tri & (dt > 1e-5) & same_plane_point] = "rounding"
    kind[same_tri & (dt <= 1e-5)] = "same"
    diff = both & (a_tri != b_tri)
    ta, tb = T[np.where(diff, a_tri, 0)], T[np.where(diff, b_tri, 0)]
    shares = (ta[:, :, None] == tb[:, None, :]).any(axis=(1, 2))
    tie = diff & ((dt <= 1e-6) | same_point)
    kind[tie & shares & a_edge & b_edge] = "shared_edge_vertex"  # neighbours share only their edge
    kind[tie & ~shares] = "coincident_faces"
    a_nearer = a_t < b_t
    kind[diff & ~tie & a_nearer & a_edge] = "edge_ray"
    kind[diff & ~tie & ~a_nearer & b_edge] = "edge_ray_passed"
    return {k: int((kind == k).sum()) for k in DISAGREEMENT_KINDS} | {"rays": len(a_t)}


def run_blender(config, data_dir, native):
    names = [name for name, _ in config["meshes"]]
    log("Blender BVHTree", ",".join(names))
    subprocess.run([*BLENDER, "--python", str(ROOT / "tools" / "bench_blender.py"), "--",
                    "--dir", str(data_dir), "--names", ",".join(names), "--reps", str(config["blender_reps"])],
                   check=True, stdout=subprocess.DEVNULL)
    blender = json.loads((data_dir / "blender.json").read_text())
    for name in names:
        V = np.load(data_dir / f"{name}.vertices.npy")
        T = np.load(data_dir / f"{name}.triangles.npy").astype(np.int64)
        entry = blender["meshes"][name]
        embree = {t["name"]: t for t in native[name]["tracers"]}["embree_medium"]
        entry["build"]["ratio_to_embree_medium"] = (entry["build"]["seconds_median"]
                                                     / embree["build"]["1"]["seconds_median"])
        for ray_set, timing in entry["ray_sets"].items():
            ours = np.load(data_dir / f"{name}.blender_{ray_set}.npy")
            theirs = np.load(data_dir / f"{name}.embree_{ray_set}.npy")
            rays = np.load(data_dir / f"{name}.rays_{ray_set}.npy")
            timing["agreement_with_embree"] = classify(V, T, rays[:, 0:3], rays[:, 4:7],
                                                       ours[:, 0], ours[:, 1].astype(np.int64),
                                                       theirs[:, 0], theirs[:, 1].astype(np.int64))
            ref = run_lookup(embree, ray_set, "closest", 1)
            timing["ratio_to_embree_medium_1t"] = timing["rays_per_second"] / ref["rays_per_second"]
    return blender


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


def renderer_available():
    return hasattr(raylab, "render")


def render_once(V, T, structure, camera, lights, materials, **settings):
    scene = raylab.Scene(structure=structure, max_depth=6, leaf_size=8)
    scene.add_instance(scene.add_mesh(V, T), np.eye(4), material=0)
    scene.commit()
    base = dict(super_sampling=1, max_depth=3, shadows=True, background=(0.05, 0.05, 0.05),
                ambient=(1.0, 1.0, 1.0), threads=0)
    return raylab.render(scene, camera, lights, materials, base | settings)


def camera_primary_rays(camera, super_sampling):
    """The primary rays of the thesis camera (NxN stratified sub-pixel positions), for the fallback
    without the renderer: Blender's perspective model with horizontal sensor fit."""
    w, h = camera["resolution_x"], camera["resolution_y"]
    m = camera["matrix_world"]
    half_w = 0.5 * camera["sensor_width"] / camera["lens"]
    half_h = half_w * h / w
    s = super_sampling
    sub = (np.arange(s) + 0.5) / s
    xs = (np.arange(w)[:, None] + sub[None, :]).ravel()
    ys = (np.arange(h)[:, None] + sub[None, :]).ravel()
    gx, gy = np.meshgrid(xs, ys)
    local = np.stack([(2 * gx / w - 1) * half_w, (1 - 2 * gy / h) * half_h, -np.ones_like(gx)], -1).reshape(-1, 3)
    directions = local @ m[:3, :3].T
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return np.broadcast_to(m[:3, 3], directions.shape).astype(np.float32), directions.astype(np.float32)


def run_thesis(config):
    """Render seconds (median of reps) and ray-triangle tests per structure and super-sampling,
    side by side with the thesis; the images feed the speed-against-accuracy chart."""
    cfg = config["thesis"]
    V, T = raylab.load_mesh(MESH_DIR / "goathead.obj")
    camera, lights, materials = thesis_setup(V, cfg["width"], cfg["height"])
    use_renderer = renderer_available()
    log("thesis experiment", "with raylab.render" if use_renderer else "primary rays only (no raylab.render)")
    rows, images = [], {}
    for structure in built_structures():
        for ss in cfg["super_sampling"]:
            reps = cfg["reps"] if ss <= len(THESIS["render_seconds"]["none"]) else 1  # the thesis's levels
            seconds, stats = [], None
            for _ in range(reps):
                if use_renderer:
                    res = render_once(V, T, structure, camera, lights, materials, super_sampling=ss)
                    seconds.append(res.stats["render_seconds"])
                    stats = {k: res.stats[k] for k in ("rays_primary", "rays_shadow", "rays_ignored", "box_tests",
                                                       "triangle_tests", "build_seconds")}
                    images[(structure, ss)] = res.image
                else:
                    s = raylab.build(V, T, structure=structure)
                    origins, directions = camera_primary_rays(camera, ss)
                    start = time.perf_counter()
                    h = s.intersect(origins, directions, count=True)
                    seconds.append(time.perf_counter() - start)
                    stats = dict(h.stats, rays_primary=len(origins), build_seconds=s.build_seconds)
            rows.append(dict(structure=structure, super_sampling=ss, repetitions=reps,
                             render_seconds_median=statistics.median(seconds), render_seconds=seconds, **stats))
    result = {"mode": "render" if use_renderer else "primary_rays_only",
              "note": ("raylab.render, Whitted shading with shadows, one point light" if use_renderer else
                       "raylab.render was not available: camera rays only, through raylab.build(...).intersect"
                       " with count=True; seconds are primary-ray tracing only"),
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
        out.append(dict(structure=structure, super_sampling=ss, rmse=rmse, psnr_db=psnr if math.isfinite(psnr) else None,
                        max_difference_to_other_structures=across))
    return out


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


def run_leaks(config, data_dir):
    """Rays from inside closed meshes towards vertices, edge midpoints and random directions: every
    one must hit. Counts the escapes and the throughput of each triangle test on the same rays."""
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
        for test in raylab.TRIANGLE_TESTS:
            s = raylab.build(V, T, structure="bvh", triangle_test=test)
            for kind, d in directions.items():
                seconds = []
                for _ in range(cfg["reps"]):
                    start = time.perf_counter()
                    h = s.intersect(origins, d)
                    seconds.append(time.perf_counter() - start)
                med = statistics.median(seconds)
                out.append(dict(mesh=name, triangles=len(T), triangle_test=test, rays=kind, ray_count=n,
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
    if not renderer_available():
        return {"skipped": "raylab.render is not available"}
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
        base = dict(super_sampling=1, max_depth=1, background=(0, 0, 0), ambient=(1, 1, 1))
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


# ---------------------------------------------------------------- output

def thesis_structures(thesis):
    return list(dict.fromkeys(r["structure"] for r in thesis["rows"]))


def fmt_rate(x):
    return "-" if x is None else (f"{x / 1e6:.2f} M" if x >= 1e6 else f"{x / 1e3:.1f} k")


def disagreement_examples(results):
    """One example ray per mesh, structure and kind of disagreement, with both hits re-solved in double
    precision: the referee says which tracer was off, and by how much."""
    def hit(h):
        if h is None:
            return "miss", "-"
        edge = ", on edge" if h["on_edge"] else ""
        return f"{h['triangle']} at t {h['t']:.7g}{edge}", f"{h['double_t']:.9g}"

    lines = ["Examples (the first disagreement of each kind; *double t* is the ray against that triangle solved "
             "in double precision):", "",
             "| mesh | structure | rays | query | kind | raylab hit | double t | Embree hit | double t |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, mesh in results["meshes"].items():
        for t in mesh["tracers"]:
            if t["kind"] != "raylab" or t["error"] or t["name"] not in ("octree", "bvh"):
                continue
            for ray_set, per in t["tracing"]["per_ray_set"].items():
                for query, counts in per["agreement_with_embree"].items():
                    seen = set()
                    for e in counts.get("examples", []):
                        if e["kind"] in seen:
                            continue
                        seen.add(e["kind"])
                        ours, theirs = hit(e["raylab"]), hit(e["embree"])
                        lines.append(f"| {name} | {t['name']} | {ray_set} | {query} | {e['kind']} | {ours[0]} | "
                                     f"{ours[1]} | {theirs[0]} | {theirs[1]} |")
    if len(lines) == 4:
        lines.append("| (no disagreement) | | | | | | | | |")
    return lines + [""]


def markdown(results):
    lines = ["# raylab benchmark", "",
             f"{results['machine']['date']}, {results['machine']['hardware_threads']} hardware threads, "
             f"Embree {results['machine']['embree']}, Blender {results['blender'].get('blender_version', '-')}. "
             "Rays/s are medians of repetitions in this run; ratios are raylab / Embree (medium quality) "
             "on the same rays.", ""]
    lines += ["## Throughput, build and memory", "",
              "| mesh | tris | tracer | build s (2t) | bytes/tri | camera closest 1t | 2t | camera any 2t "
              "| random closest 1t | 2t | random any 2t | boxes/ray | tris/ray | BVH/Embree camera | random | build |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, mesh in results["meshes"].items():
        for t in mesh["tracers"]:
            if t["error"]:
                lines.append(f"| {name} | {mesh['triangles']:,} | {t['name']} | error: {t['error']} |" + " |" * 12)
                continue
            rate = lambda s, q, n: (run_lookup(t, s, q, n) or {}).get("rays_per_second")  # noqa: E731
            counts = t["tracing"]["per_ray_set"].get("camera", {}).get("counts", {}).get("closest")
            r = t.get("ratios_to_embree_medium", {})
            tests = (f"| {counts['box_tests_per_ray']:.1f} | {counts['triangle_tests_per_ray']:.1f} " if counts
                     else "| - | - ")
            lines.append(
                f"| {name} | {mesh['triangles']:,} | {t['name']} | {t['build']['2']['seconds_median']:.4f} "
                f"| {t['memory_bytes'] / mesh['triangles']:.1f} "
                f"| {fmt_rate(rate('camera', 'closest', 1))} | {fmt_rate(rate('camera', 'closest', 2))} "
                f"| {fmt_rate(rate('camera', 'any', 2))} | {fmt_rate(rate('random', 'closest', 1))} "
                f"| {fmt_rate(rate('random', 'closest', 2))} | {fmt_rate(rate('random', 'any', 2))} " + tests)
            if r:
                lines[-1] += (f"| {r['camera_closest_2t_rays_per_second']:.2f} | {r['random_closest_2t_rays_per_second']:.2f} "
                              f"| {r['build_2t_seconds']:.2f} |")
            else:
                lines[-1] += "| | | |"
        b = results["blender"].get("meshes", {}).get(name)
        if b:
            rs = b["ray_sets"]
            lines.append(f"| {name} | {mesh['triangles']:,} | Blender BVHTree (Python loop) | "
                         f"{b['build']['seconds_median']:.4f} (1t) | - | {fmt_rate(rs['camera']['rays_per_second'])} "
                         f"| - | - | {fmt_rate(rs['random']['rays_per_second'])} | - | - | - | - "
                         f"| {rs['camera']['ratio_to_embree_medium_1t']:.2f} (1t) "
                         f"| {rs['random']['ratio_to_embree_medium_1t']:.2f} (1t) "
                         f"| {b['build']['ratio_to_embree_medium']:.2f} (1t) |")
    lines += ["", "Rays that raylab's `none` and `aabb` trace are a spread subset of each set (they are O(T) "
              "per ray); each tracer's rays/s is over the rays it traced. Blender's BVHTree is a Python loop "
              "of `ray_cast` on one thread (it has no any-hit query), on a subset of the same rays.", ""]
    lines += ["## Hits compared with Embree on every benchmark ray", "",
              "| mesh | tracer | rays | query | " + " | ".join(DISAGREEMENT_KINDS) + " |",
              "|---|---|---|---|" + "---|" * len(DISAGREEMENT_KINDS)]
    for name, mesh in results["meshes"].items():
        for t in mesh["tracers"]:
            if t["kind"] != "raylab" or t["error"]:
                continue
            for ray_set, per in t["tracing"]["per_ray_set"].items():
                for query, counts in per["agreement_with_embree"].items():
                    lines.append(f"| {name} | {t['name']} | {ray_set} | {query} | "
                                 + " | ".join(str(counts.get(k, 0)) for k in DISAGREEMENT_KINDS) + " |")
        for ray_set, b in results["blender"].get("meshes", {}).get(name, {}).get("ray_sets", {}).items():
            c = b["agreement_with_embree"]
            lines.append(f"| {name} | Blender BVHTree | {ray_set} | closest | "
                         + " | ".join(str(c.get(k, 0)) for k in DISAGREEMENT_KINDS) + " |")
    lines += ["", "Kinds: *same* (both miss, or the same triangle at t within 1e-5 relative); *rounding* (the same "
              "triangle, t differs, but both hit points lie on its plane within 1e-6 of the coordinates' magnitude: a "
              "slide along the face, which a short t or a grazing ray magnifies); *shared_edge_vertex* (different triangles sharing a vertex at the "
              "same point, on an edge of both: an exact edge or vertex hit owned by both); *coincident_faces* "
              "(different triangles without a shared vertex at the same point: overlapping faces); *edge_ray* (the row's tracer hits a triangle on its edge, within 1e-5 barycentric or "
              "1e-6 of the magnitude of the corners and the ray origin, where Embree misses or hits farther: "
              "Embree's default test is not watertight); *edge_ray_passed* (the reverse: Embree hits an edge the "
              "row's tracer passes); "
              "*grazing* (same triangle, t differs, ray almost parallel to the face); *unexplained*.", ""]
    lines += disagreement_examples(results)
    th = results["thesis"]
    structures = thesis_structures(th)
    lines += [f"## The VRT thesis experiment (section 6.1), {th['width']}x{th['height']} pixels", "", th["note"] + ".", "",
              "| super-sampling | " + " | ".join(f"raylab {s} s" for s in structures)
              + " | thesis none s | thesis aabb s | thesis octree s |", "|---|" + "---|" * (len(structures) + 3)]
    by = {(r["structure"], r["super_sampling"]): r for r in th["rows"]}
    for i, ss in enumerate(sorted({r["super_sampling"] for r in th["rows"]})):
        thesis = [THESIS["render_seconds"][s][i] if i < 3 else None for s in ("none", "aabb", "octree")]
        lines.append(f"| {ss} | " + " | ".join(f"{by[(s, ss)]['render_seconds_median']:.4f}" for s in structures)
                     + " | " + " | ".join("-" if x is None else f"{x:.4f}" for x in thesis) + " |")
    lines += ["", "| super-sampling | " + " | ".join(f"raylab {s} tests" for s in structures)
              + " | thesis none | thesis aabb | thesis octree |", "|---|" + "---|" * (len(structures) + 3)]
    for i, ss in enumerate(sorted({r["super_sampling"] for r in th["rows"]})):
        thesis = [THESIS["triangle_tests"][s][i] if i < 3 else None for s in ("none", "aabb", "octree")]
        lines.append(f"| {ss} | " + " | ".join(f"{by[(s, ss)]['triangle_tests']:,}" for s in structures)
                     + " | " + " | ".join("-" if x is None else f"{x:,}" for x in thesis) + " |")
    if th.get("image_error"):
        lines += ["", f"Image error against the reference, the same scene rendered at super-sampling "
                  f"{th['reference_super_sampling']}x{th['reference_super_sampling']}:", "", "| structure | super-sampling | render s | RMSE | PSNR dB | max diff to other structures |",
                  "|---|---|---|---|---|---|"]
        for e in th["image_error"]:
            r = by[(e["structure"], e["super_sampling"])]
            psnr = f"{e['psnr_db']:.1f}" if e["psnr_db"] else "inf"
            lines.append(f"| {e['structure']} | {e['super_sampling']} | {r['render_seconds_median']:.4f} "
                         f"| {e['rmse']:.5f} | {psnr} | {e['max_difference_to_other_structures']:.2g} |")
    lines += ["", "## Rays escaping closed meshes from inside", "",
              "| mesh | triangles | test | rays aimed at | rays | escaped | rays/s |", "|---|---|---|---|---|---|---|"]
    for r in results["leaks"]:
        lines.append(f"| {r['mesh']} | {r['triangles']:,} | {r['triangle_test']} | {r['rays']} | {r['ray_count']} "
                     f"| {r['escaped']} | {fmt_rate(r['rays_per_second'])} |")
    sh = results["self_hits"]
    lines += ["", "## False self-hits of shadow rays against scene scale", ""]
    if "rows" in sh:
        methods = list(dict.fromkeys(r["method"] for r in sh["rows"]))
        lines += ["Convex sphere, sun light: every lit pixel darkened by its own shadow ray is a false self-hit "
                  "(share of lit pixels).", "", "| scale | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
        for scale in dict.fromkeys(r["scale"] for r in sh["rows"]):
            cells = [next(r for r in sh["rows"] if r["scale"] == scale and r["method"] == m) for m in methods]
            lines.append(f"| {scale:g} | " + " | ".join(f"{c['false_self_hits']} ({100 * c['fraction']:.1f}%)" for c in cells) + " |")
    else:
        lines.append(sh["skipped"])
    lines += ["", "Charts: " + ", ".join(f"`{c}`" for c in results["charts"]), ""]
    return "\n".join(lines)


def legend_below(fig, ax, columns):
    """One legend for the whole figure, under the plots, where it hides no bar or line."""
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=columns, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.09, 1, 1))


def chart_throughput(results, path):
    meshes = list(results["meshes"])
    names = ["none", "aabb", "octree", "bvh", "embree_medium", "embree_high"]
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.2))
    for ax, ray_set in zip(axes, ("camera", "random")):
        width = 0.8 / (len(names) + 1)
        for i, tracer in enumerate(names):
            values = []
            for m in meshes:
                t = {x["name"]: x for x in results["meshes"][m]["tracers"]}.get(tracer)
                run = run_lookup(t, ray_set, "closest", 2) if t and not t["error"] else None
                values.append(run["rays_per_second"] if run else 0)
            ax.bar(np.arange(len(meshes)) + i * width, values, width, label=tracer.replace("_", " "))
        blender = [results["blender"].get("meshes", {}).get(m, {}).get("ray_sets", {}).get(ray_set, {})
                   .get("rays_per_second", 0) for m in meshes]
        ax.bar(np.arange(len(meshes)) + len(names) * width, blender, width, label="Blender BVHTree (1 thread)",
               color="0.5")
        ax.set_yscale("log")
        ax.set_xticks(np.arange(len(meshes)) + 0.4 - width / 2)
        ax.set_xticklabels([f"{m}\n{results['meshes'][m]['triangles']:,} tris" for m in meshes])
        ax.set_ylabel("closest-hit rays per second (2 threads)")
        ax.set_title(f"{ray_set} rays: closest hit throughput")
        ax.grid(axis="y", which="both", alpha=0.3)
    legend_below(fig, axes[1], len(names) + 1)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def chart_ratios(results, path):
    meshes = list(results["meshes"])
    keys = [("camera_closest_2t_rays_per_second", "camera closest rays/s"),
            ("camera_any_2t_rays_per_second", "camera any-hit rays/s"),
            ("random_closest_2t_rays_per_second", "random closest rays/s"),
            ("random_any_2t_rays_per_second", "random any-hit rays/s"),
            ("build_2t_seconds", "build seconds"), ("memory_bytes", "memory bytes")]
    fig, ax = plt.subplots(figsize=(11, 4.9))
    width = 0.8 / len(keys)
    for i, (key, label) in enumerate(keys):
        values = []
        for m in meshes:
            bvh = {x["name"]: x for x in results["meshes"][m]["tracers"]}["bvh"]
            values.append(bvh.get("ratios_to_embree_medium", {}).get(key, 0))
        ax.bar(np.arange(len(meshes)) + i * width, values, width, label=label)
    ax.axhline(1.0, color="k", lw=1)
    ax.set_xticks(np.arange(len(meshes)) + 0.4 - width / 2)
    ax.set_xticklabels(meshes)
    embree = f"Embree {results['machine']['embree']}"
    ax.set_ylabel(f"raylab BVH / {embree} (ratio)")
    ax.set_title(f"raylab BVH against {embree} on the same rays, 2 threads (1 = equal; rays/s above 1 is faster, "
                 "seconds and bytes above 1 are worse)", fontsize=9)
    ax.grid(axis="y", alpha=0.3)
    legend_below(fig, ax, len(keys))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def chart_thesis(results, path):
    th = results["thesis"]
    levels = sorted({r["super_sampling"] for r in th["rows"]})
    by = {(r["structure"], r["super_sampling"]): r for r in th["rows"]}
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.0))
    for s in thesis_structures(th):
        axes[0].plot(levels, [by[(s, ss)]["render_seconds_median"] for ss in levels], "o-", label=f"raylab {s}")
        axes[1].plot(levels, [by[(s, ss)]["triangle_tests"] for ss in levels], "o-", label=f"raylab {s}")
    for s in ("none", "aabb", "octree"):
        axes[0].plot([1, 2, 3], THESIS["render_seconds"][s], "x--", label=f"VRT thesis {s}")
        axes[1].plot([1, 2, 3], THESIS["triangle_tests"][s], "x--", label=f"VRT thesis {s}")
    axes[0].set_ylabel("render time (s, median)")
    axes[1].set_ylabel("ray-triangle tests")
    for ax in axes:
        ax.set_yscale("log")
        ax.set_xlabel("super-sampling N (NxN samples per pixel)")
        ax.set_xticks(levels)
        ax.grid(which="both", alpha=0.3)
    mode = "raylab.render" if th["mode"] == "render" else "primary rays only"
    axes[0].set_title(f"Goat head render time ({mode}, {th['width']}x{th['height']}) vs the VRT thesis")
    axes[1].set_title("Ray-triangle tests vs the VRT thesis (Table 4)")
    legend_below(fig, axes[0], 7)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def chart_speed_accuracy(results, path):
    th = results["thesis"]
    by = {(r["structure"], r["super_sampling"]): r for r in th["rows"]}
    fig, ax = plt.subplots(figsize=(8, 5))
    for s in thesis_structures(th):
        points = [(by[(e["structure"], e["super_sampling"])]["render_seconds_median"], e["psnr_db"], e["super_sampling"])
                  for e in th["image_error"] if e["structure"] == s and e["psnr_db"] is not None]
        if not points:
            continue
        ax.plot([p[0] for p in points], [p[1] for p in points], "o-", label=s)
        for x, y, ss in points:
            ax.annotate(f"{ss}x{ss}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.set_xscale("log")
    ax.set_xlabel("render time (s, median)")
    ax.set_ylabel(f"PSNR against the {th['reference_super_sampling']}x{th['reference_super_sampling']} "
                  "super-sampled render (dB)")
    ax.set_title("Speed against accuracy: the same images, at each structure's cost")
    ax.grid(which="both", alpha=0.3)
    ax.legend(title="structure")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def chart_leaks(results, path):
    rows = results["leaks"]
    labels = list(dict.fromkeys(f"{r['mesh']}\n{r['rays']}" for r in rows))
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for i, test in enumerate(raylab.TRIANGLE_TESTS):
        sel = {f"{r['mesh']}\n{r['rays']}": r for r in rows if r["triangle_test"] == test}
        x = np.arange(len(labels)) + i * 0.4
        axes[0].bar(x, [100 * sel[l]["escaped"] / sel[l]["ray_count"] for l in labels], 0.4, label=test)
        axes[1].bar(x, [sel[l]["rays_per_second"] / 1e6 for l in labels], 0.4, label=test)
    axes[0].set_ylabel("rays escaping the closed mesh (%)")
    axes[0].set_title("Rays from inside a closed mesh that escape (must be 0)")
    axes[1].set_ylabel("closest-hit rays per second, millions (BVH, all threads)")
    axes[1].set_title("Throughput of each triangle test on the same rays")
    for ax in axes:
        ax.set_xticks(np.arange(len(labels)) + 0.2)
        ax.set_xticklabels(labels, fontsize=7)
        ax.legend()
        ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def chart_self_hits(results, path):
    rows = results["self_hits"]["rows"]
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for method in dict.fromkeys(r["method"] for r in rows):
        sel = [r for r in rows if r["method"] == method]
        ax.plot([r["scale"] for r in sel], [100 * r["fraction"] for r in sel], "o-", label=method)
    ax.set_xscale("log")
    ax.set_xlabel("scene scale (object size and distance from the origin, scene units)")
    ax.set_ylabel("lit pixels falsely self-shadowed (%)")
    ax.set_title("Shadow acne against scene scale: fixed epsilon vs the robust ulp offset")
    ax.grid(which="both", alpha=0.3)
    ax.legend(title="secondary-ray origin")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_charts(results, out):
    charts = {"bench_throughput.png": chart_throughput, "bench_embree_ratio.png": chart_ratios,
              "bench_thesis.png": chart_thesis, "bench_leaks.png": chart_leaks}
    if results["thesis"].get("image_error"):
        charts["bench_speed_accuracy.png"] = chart_speed_accuracy
    if "rows" in results["self_hits"]:
        charts["bench_self_hits.png"] = chart_self_hits
    for name, draw in charts.items():
        draw(results, out / name)
    return sorted(charts)


# Where each chart is shown: the level folders hold them as diagrams (the installed add-on carries the
# levels), and the README embeds them from there; the full table goes to docs/bench/results.md.
PUBLISHED = {"bench_throughput.png": "race", "bench_embree_ratio.png": "race", "bench_thesis.png": "race",
             "bench_speed_accuracy.png": "race", "bench_leaks.png": "where_methods_fail",
             "bench_self_hits.png": "where_methods_fail"}


def publish(results, out):
    if results["configuration"] != "full":
        sys.exit("bench: --publish takes the charts of a full run (./raylab bench without --quick)")
    for chart, level in PUBLISHED.items():
        target = ROOT / "levels" / level / "diagrams" / chart
        shutil.copyfile(out / chart, target)
        log(f"published {target.relative_to(ROOT)}")
    shutil.copyfile(out / "results.md", ROOT / "docs" / "bench" / "results.md")
    log("published docs/bench/results.md")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a tiny configuration, well under a minute")
    parser.add_argument("--out", default=str(ROOT / "out" / "bench"))
    parser.add_argument("--build-dir", default=os.environ.get("RAYLAB_BUILD_DIR", str(ROOT / "build")))
    parser.add_argument("--no-blender", action="store_true", help="skip Blender's BVHTree")
    parser.add_argument("--replot", action="store_true",
                        help="redraw the charts and the table from <out>/results.json, measuring nothing")
    parser.add_argument("--publish", action="store_true",
                        help="copy the charts of a full run into the levels that show them (and the README)")
    args = parser.parse_args()
    out = Path(args.out)
    if args.replot or args.publish:
        results = json.loads((out / "results.json").read_text())
        if args.replot:
            results["charts"] = write_charts(results, out)
            (out / "results.json").write_text(json.dumps(results, indent=1))
            (out / "results.md").write_text(markdown(results))
        if args.publish:
            publish(results, out)
        return
    config = QUICK if args.quick else FULL
    data = out / "data"
    data.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()

    native = run_native(config, bench_binary(args.build_dir), data)
    blender = {} if args.no_blender else run_blender(config, data, native)
    thesis = run_thesis(config)
    leaks = run_leaks(config, data)
    self_hits = run_self_hits(config)
    first = next(iter(native.values()))
    results = {"configuration": "quick" if args.quick else "full",
               "machine": {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                           "hardware_threads": first["hardware_threads"], "embree": first["embree_version"],
                           "platform": platform.platform()},
               "meshes": native, "blender": blender, "thesis": thesis, "leaks": leaks, "self_hits": self_hits}
    results["charts"] = write_charts(results, out)
    results["seconds_total"] = time.perf_counter() - started
    (out / "results.json").write_text(json.dumps(results, indent=1))
    (out / "results.md").write_text(markdown(results))
    print(markdown(results))
    log(f"done in {results['seconds_total']:.0f} s: {out / 'results.md'}")


if __name__ == "__main__":
    main()
