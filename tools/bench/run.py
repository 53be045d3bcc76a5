"""Runs the native benchmark (raylab_bench: raylab's structures and Embree on the same rays) and Blender's
BVHTree on the rays it exported, and compares every tracer with Embree (medium quality)."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from . import MESH_DIR, ROOT, log

BLENDER = ["blender", "-b", "--factory-startup", "--python-exit-code", "1"]
# The kinds of disagreement of native/bench/hit_comparison.cpp, most benign first (its JSON keys).
DISAGREEMENT_KINDS = ("same", "rounding", "shared_edge_vertex", "coincident_faces", "edge_ray", "edge_ray_passed",
                      "grazing", "embree_wrong", "raylab_wrong", "referee_tie", "unexplained")
# The float64 referee's verdicts (native/bench/arbitration.h), right first.
VERDICTS = ("right", "off_triangle", "outside_interval", "missed_inside", "leaked")


# ---------------------------------------------------------------- raylab_bench and Embree

def bench_binary(build_dir):
    path = Path(build_dir) / "raylab_bench"
    if not path.exists():
        sys.exit(f"bench: {path} not found; build with embree (libembree-dev) first: ./raylab setup")
    return path


def mesh_spec(source):
    """raylab_bench's --mesh for a configured source: icosphere:LEVELS as it is; a shipped OBJ file, or
    subdivided:LEVELS:FILE (its triangles split 4^LEVELS ways: the dragon at 1.6M), from MESH_DIR."""
    if source.startswith("icosphere:"):
        return source
    if source.startswith("subdivided:"):
        levels, file = source[len("subdivided:"):].split(":", 1)
        return f"subdivided:{levels}:{MESH_DIR / file}"
    return str(MESH_DIR / source)


def run_native(config, binary, data_dir, arguments=None, after_each=None):
    """raylab_bench on every mesh of the configuration (with `arguments`, or the configuration's), each
    mesh's results read back with their ratios; `after_each(name, results)` runs right after each mesh's
    run, so that what it measures (the user's path) lies next to it in time."""
    results = {}
    for name, source in config["meshes"]:
        log(f"raylab_bench {name}")
        subprocess.run([str(binary), "--mesh", mesh_spec(source), "--name", name, "--out", str(data_dir),
                        *(arguments or config["native"])], check=True)
        results[name] = json.loads((data_dir / f"{name}.json").read_text())
        add_ratios(results[name])
        if after_each:
            after_each(name, results[name])
    return results


def run_lookup(tracer, ray_set, query, threads):
    for run in tracer.get("tracing", {}).get("runs", []):
        if (run["rays"], run["query"], run["threads"]) == (ray_set, query, threads):
            return run
    return None


def add_ratios(mesh):
    """raylab / Embree (medium) for every raylab structure: rays/s ratios (< 1: slower than Embree),
    build-time and memory ratios (> 1: slower / bigger); and rays/s against Embree's packet API
    (embree_packets: rtcIntersect8 / rtcOccluded8 on the medium scene) where it ran."""
    tracers = {t["name"]: t for t in mesh["tracers"]}
    embree, packets = tracers["embree_medium"], tracers.get("embree_packets")
    for t in mesh["tracers"]:
        if t["kind"] != "raylab" or t["error"]:
            continue
        ratios, to_packets = {}, {}
        for run in t["tracing"]["runs"]:
            ref = run_lookup(embree, run["rays"], run["query"], run["threads"])
            key = f'{run["rays"]}_{run["query"]}_{run["threads"]}t_rays_per_second'
            ratios[key] = run["rays_per_second"] / ref["rays_per_second"]
            ref = run_lookup(packets, run["rays"], run["query"], run["threads"]) if packets else None
            if ref:
                to_packets[key] = run["rays_per_second"] / ref["rays_per_second"]
        if packets:
            t["ratios_to_embree_packets"] = to_packets
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
