"""Measures raylab's four structures on meshes and prints a Markdown table: build time, memory, closest-hit
rays per second for camera rays and random rays (median of several runs; TBB on all cores), and box
and triangle tests per ray (from a separate counting run, so counting never slows the timed runs).

    /usr/bin/python3 tools/core_table.py [mesh.obj ...] [--rays N] [--slow-rays N] [--runs N]

The rays are those of the equivalence tests (raylab.rays): a pinhole camera framing the mesh,
and random rays from the enlarged bounding box. `none` and `aabb` test every triangle of every ray
(that enters the box), so they trace fewer rays (--slow-rays); rates are per ray either way.
"""
import argparse
import os
import pathlib
import statistics
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "addon"))

import numpy as np  # noqa: E402

import raylab  # noqa: E402
from raylab import rays  # noqa: E402

MESH_DIR = ROOT / "addon" / "raylab" / "meshes"
SLOW = ("none", "aabb")


def median_rate(structure, origins, directions, runs):
    seconds = []
    for _ in range(runs):
        start = time.perf_counter()
        structure.intersect(origins, directions)
        seconds.append(time.perf_counter() - start)
    return len(origins) / statistics.median(seconds)


def per_ray(structure, origins, directions):
    stats = structure.intersect(origins, directions, count=True).stats
    return stats["box_tests"] / stats["rays"], stats["triangle_tests"] / stats["rays"]


def measure(path, args):
    vertices, triangles = raylab.load_mesh(path)
    side = int(round(np.sqrt(args.rays)))
    camera = rays.camera_rays(vertices, side)
    random = rays.random_rays(vertices, side * side, np.random.default_rng(1))
    rows = []
    for name in raylab.STRUCTURES:
        s = raylab.build(vertices, triangles, structure=name)
        n = args.slow_rays if name in SLOW else len(camera[0])
        # The slow structures trace an evenly spread subset, so that it still covers the whole frame.
        pick = np.linspace(0, len(camera[0]) - 1, n).astype(np.int64)
        cam = (camera[0][pick], camera[1][pick])
        rnd = (random[0][:n], random[1][:n])
        build = statistics.median([s.build_seconds] + [raylab.build(vertices, triangles, structure=name).build_seconds
                                                       for _ in range(args.runs - 1)])
        rows.append(dict(
            structure=name, rays=n, build_ms=1e3 * build, memory=s.memory_bytes,
            camera=median_rate(s, *cam, args.runs), random=median_rate(s, *rnd, args.runs),
            camera_tests=per_ray(s, *cam), random_tests=per_ray(s, *rnd)))
    return len(triangles), rows


def table(results, args):
    lines = [
        "| mesh | triangles | structure | rays | build ms | memory bytes | bytes/tri | camera rays/s | "
        "random rays/s | box tests/ray cam / rnd | triangle tests/ray cam / rnd |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for mesh, (count, rows) in results.items():
        for r in rows:
            lines.append(
                f"| {mesh} | {count:,} | {r['structure']} | {r['rays']:,} | {r['build_ms']:.1f} | {r['memory']:,} | "
                f"{r['memory'] / count:.1f} | {r['camera']:,.0f} | {r['random']:,.0f} | "
                f"{r['camera_tests'][0]:.1f} / {r['random_tests'][0]:.1f} | "
                f"{r['camera_tests'][1]:.1f} / {r['random_tests'][1]:.1f} |")
    lines.append("")
    fast_rays = max(r["rays"] for _, rows in results.values() for r in rows)
    lines.append(f"Closest hit, {os.cpu_count()} threads (TBB), median of {args.runs} runs; `none` and `aabb` "
                 f"trace {args.slow_rays:,} rays per set, the others {fast_rays:,}.")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("meshes", nargs="*", default=["bunny_hr.obj", "dragon.obj"],
                        help="OBJ files (names alone are looked up in the add-on's meshes folder)")
    parser.add_argument("--rays", type=int, default=250_000, help="rays per set for octree and bvh")
    parser.add_argument("--slow-rays", type=int, default=2_000, help="rays per set for none and aabb")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    results = {}
    for mesh in args.meshes:
        path = pathlib.Path(mesh)
        if not path.exists():
            path = MESH_DIR / mesh
        results[path.name] = measure(path, args)
    print(table(results, args))


if __name__ == "__main__":
    main()
