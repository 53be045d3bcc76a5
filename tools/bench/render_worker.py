"""One process's renders for the render experiment (experiments.run_render): the scene built, rendered
`--renders` times on one thread (pinned to one core) at each super sampling, the renderer's own
seconds and the process's CPU seconds of each render printed as JSON. Which raylab renders is the
add-on folder in RAYLAB_BENCH_ADDON (tools/bench/__init__.py), so that two checkouts' renderers run
the same code here.

    RAYLAB_BENCH_ADDON=CHECKOUT/addon /usr/bin/python3 -m tools.bench.render_worker --scene demo \
        --size 160x120 --super-sampling 1,2,3 --renders 3
"""
import argparse
import json
import os
import time

import numpy as np

import raylab

from . import MESH_DIR
from .experiments import thesis_setup


def subdivided(V, T, levels):
    """Every triangle split in four at its edges' midpoints, `levels` times (as raylab_bench's
    subdivided:LEVELS:FILE; the corners repeated per triangle, which the renderer does not mind)."""
    for _ in range(levels):
        a, b, c = (V[T[:, k]] for k in range(3))
        ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
        V = np.concatenate([a, b, c, ab, bc, ca]).astype(np.float32)
        n = len(T)
        i = np.arange(n, dtype=np.uint32)
        A, B, C, AB, BC, CA = (i + k * n for k in range(6))
        T = np.concatenate([np.stack(t, axis=1) for t in ((A, AB, CA), (B, BC, AB), (C, CA, BC), (AB, BC, CA))])
    return V, T


def build_scene(name, width, height):
    """demo: the goat head over a floor (the demo's mesh); dragon_1600k: the dragon subdivided twice. A
    point light above the camera, one diffuse material, the exact contract."""
    V, T = raylab.load_mesh(MESH_DIR / ("goathead.obj" if name == "demo" else "dragon.obj"))
    if name == "dragon_1600k":
        V, T = subdivided(V, T, 2)
    camera, lights, materials = thesis_setup(V, width, height)
    scene = raylab.Scene(structure="bvh")
    scene.add_instance(scene.add_mesh(V, T), np.eye(4), material=0)
    if name == "demo":
        lo, hi = V.min(0), V.max(0)
        size = 2.0 * float(np.linalg.norm(hi - lo))
        mid = (lo + hi) / 2
        floor = np.array([[mid[0] - size, mid[1] - size, lo[2]], [mid[0] + size, mid[1] - size, lo[2]],
                          [mid[0] + size, mid[1] + size, lo[2]], [mid[0] - size, mid[1] + size, lo[2]]], np.float32)
        scene.add_instance(scene.add_mesh(floor, np.array([[0, 1, 2], [0, 2, 3]], np.uint32)), np.eye(4), material=0)
    scene.commit()
    return scene, camera, lights, materials, len(T) + (2 if name == "demo" else 0)


def main():
    parser = argparse.ArgumentParser(prog="render_worker")
    parser.add_argument("--scene", required=True, choices=("demo", "dragon_1600k"))
    parser.add_argument("--size", required=True)
    parser.add_argument("--super-sampling", required=True)
    parser.add_argument("--renders", type=int, default=3)
    args = parser.parse_args()
    width, height = (int(x) for x in args.size.split("x"))
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    scene, camera, lights, materials, triangles = build_scene(args.scene, width, height)
    out = {"scene": args.scene, "triangles": triangles, "width": width, "height": height, "renders": {}}
    for ss in (int(x) for x in args.super_sampling.split(",")):
        settings = dict(super_sampling=ss, max_recursion=3, shadows=True, background=(0.05, 0.05, 0.05),
                        ambient=(1.0, 1.0, 1.0), threads=1)
        raylab.render(scene, camera, lights, materials, settings)  # warm-up
        seconds, cpu = [], []
        for _ in range(args.renders):
            start = time.process_time()
            result = raylab.render(scene, camera, lights, materials, settings)
            cpu.append(time.process_time() - start)
            seconds.append(result.stats["render_seconds"])
        out["renders"][str(ss)] = {"render_seconds": seconds, "cpu_seconds": cpu}
    print(json.dumps(out))


if __name__ == "__main__":
    main()
