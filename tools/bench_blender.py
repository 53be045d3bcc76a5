"""Blender's mathutils.bvhtree.BVHTree on the benchmark's meshes and rays (run by tools/bench/run.py).

    blender -b --factory-startup --python-exit-code 1 --python tools/bench_blender.py -- \
        --dir out/bench/data --names goathead,dragon --reps 3

Reads <name>.vertices.npy, <name>.triangles.npy and <name>.rays_<set>.npy written by raylab_bench,
builds a BVHTree from the triangles, casts every ray with a Python loop of ray_cast (the way a
Blender script does it), and writes <name>.blender_<set>.npy (t, triangle, hit point; inf/-1 on
miss) and blender.json (build and ray-cast seconds, medians of --reps).
"""
import argparse
import json
import math
import os
import statistics
import sys
import time

import numpy as np
from mathutils import Vector
from mathutils.bvhtree import BVHTree


def arguments():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    parser = argparse.ArgumentParser(prog="bench_blender.py")
    parser.add_argument("--dir", required=True)
    parser.add_argument("--names", required=True)
    parser.add_argument("--reps", type=int, default=3)
    return parser.parse_args(argv)


def cast_all(tree, origins, directions):
    """The Python loop a Blender script would write: one ray_cast per ray."""
    rows = []
    for o, d in zip(origins, directions):
        location, _normal, index, distance = tree.ray_cast(o, d)
        if index is None:
            rows.append((math.inf, -1.0, math.nan, math.nan, math.nan))
        else:
            rows.append((distance, float(index), location.x, location.y, location.z))
    return rows


def bench_mesh(directory, name, reps):
    base = os.path.join(directory, name)
    vertices = np.load(base + ".vertices.npy")
    triangles = np.load(base + ".triangles.npy")
    start = time.perf_counter()
    vertex_list, triangle_list = vertices.tolist(), triangles.tolist()
    conversion = time.perf_counter() - start
    # A big mesh takes seconds per build: one build is enough to see the order of magnitude.
    build_reps = reps if len(triangles) < 200_000 else 1
    build_seconds = []
    for _ in range(build_reps):
        start = time.perf_counter()
        tree = BVHTree.FromPolygons(vertex_list, triangle_list, all_triangles=True)
        build_seconds.append(time.perf_counter() - start)
    result = {"triangles": len(triangles), "list_conversion_seconds": conversion,
              "build": {"seconds_median": statistics.median(build_seconds), "seconds": build_seconds},
              "ray_sets": {}}
    for ray_set in ("camera", "random"):
        path = f"{base}.rays_{ray_set}.npy"
        if not os.path.exists(path):
            continue
        rays = np.load(path)
        origins = [Vector(o) for o in rays[:, 0:3].tolist()]
        directions = [Vector(d) for d in rays[:, 4:7].tolist()]
        seconds = []
        for _ in range(reps):
            start = time.perf_counter()
            rows = cast_all(tree, origins, directions)
            seconds.append(time.perf_counter() - start)
        np.save(f"{base}.blender_{ray_set}.npy", np.array(rows, dtype=np.float64))
        median = statistics.median(seconds)
        result["ray_sets"][ray_set] = {"ray_count": len(rays), "seconds_median": median, "seconds": seconds,
                                       "rays_per_second": len(rays) / median}
    return result


def main():
    args = arguments()
    results = {"blender_version": ".".join(map(str, __import__("bpy").app.version)), "threads": 1, "meshes": {}}
    for name in args.names.split(","):
        results["meshes"][name] = bench_mesh(args.dir, name, args.reps)
        print(f"bench_blender: {name} done", flush=True)
    with open(os.path.join(args.dir, "blender.json"), "w") as f:
        json.dump(results, f, indent=1)


main()
