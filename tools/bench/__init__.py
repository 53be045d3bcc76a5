"""./raylab bench: measure raylab's structures against Embree (3 on Debian 12, 4 on Debian 13) and
Blender's BVHTree, reproduce the VRT thesis's render experiment (its section 6.1), chart speed against
accuracy, and play an animation with the BVH refitted against rebuilt.

    /usr/bin/python3 -m tools.bench [--quick] [--out out/bench] [--build-dir build]   (from the checkout)
    /usr/bin/python3 -m tools.bench --only animation [--quick]    (the refit experiment alone, a minute)
    /usr/bin/python3 -m tools.bench --only builders [--quick]     (the BVH's builders side by side, a minute)
    /usr/bin/python3 -m tools.bench --only render --baseline CHECKOUT [--quick]   (F12's renderer against
                                                                   another checkout's, e.g. last turn's)
    /usr/bin/python3 -m tools.bench --only api [--quick]          (the user's path: `import raylab` against
                                                                   Embree's single rays and packets, and the
                                                                   fixed cost per ray; --only door: the same)

Everything is measured in this one run, on this machine, as medians of repetitions; comparisons are
ratios on the same rays (the machines are shared and noisy: absolute times drift, ratios less).
Writes <out>/results.json, <out>/results.md and <out>/bench_*.png; the raw per-mesh files of
raylab_bench and Blender stay in <out>/data/.

The modules, one role each: `run` drives raylab_bench and Blender's BVHTree, `experiments` measures
through the Python API (the thesis render, leaks, self-hits, the animation, the builders), `report`
writes the Markdown and publishes, `charts` draws; this file holds what they share: paths, the two
configurations, the log.
"""
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# The checkout's add-on, so that `import raylab` in the modules loads the package built here; the render
# experiment's worker loads another checkout's (the renderer before this one) through RAYLAB_BENCH_ADDON.
sys.path.insert(0, os.environ.get("RAYLAB_BENCH_ADDON", str(ROOT / "addon")))

MESH_DIR = ROOT / "addon" / "raylab" / "meshes"

FULL = {
    "meshes": [("goathead", "goathead.obj"), ("bunny_hr", "bunny_hr.obj"), ("dragon", "dragon.obj"),
               ("icosphere", "icosphere:8"), ("dragon_1600k", "subdivided:2:dragon.obj")],
    "native": ["--camera", "512x384", "--random-rays", "100000", "--hostile-rays", "21000", "--export-rays", "20000",
               "--reps", "5",
               "--build-reps", "7", "--rep-seconds", "0.08", "--threads", "1,2", "--embree", "medium,high"],
    "blender_reps": 3,
    "thesis": {"width": 160, "height": 120, "super_sampling": [1, 2, 3, 4], "reps": 3, "reference_ss": 8},
    "leaks": {"meshes": ["goathead", "armadillo", "icosphere"], "rays_per_kind": 20000, "reps": 3},
    "self_hits": {"scales": [1e-3, 1e-2, 1e-1, 1, 1e1, 1e2, 1e3, 1e4, 1e5], "width": 96, "height": 72},
    "animation": {"mesh": "bunny_hr", "frames": 48, "camera": 256, "random_rays": 50000, "reps": 3},
    "builders": {"meshes": ["goathead", "bunny", "dragon"], "camera": 256, "random_rays": 50000, "reps": 5},
    # The user's path (experiments.run_api) on every mesh, right after its raylab_bench run; --only api runs
    # raylab_bench with the "native" arguments below (the BVH in both contracts, Embree medium, one thread,
    # timed by CPU time: the API then too, since the two run in separate processes on a shared machine).
    # F12's renderer (raylab.render, one thread) against a baseline checkout's, each render in its own
    # process, the two alternating: the demo's goat head over a floor and the dragon at 1.6M triangles.
    # Each scene: name, width, height, super samplings, renders per process.
    "render": {"rounds": 5, "scenes": [("demo", 160, 120, [1, 2, 3], 15), ("dragon_1600k", 640, 480, [1], 3)]},
    "api": {"reps": 7, "native": ["--cpu-time", "--camera", "512x384", "--random-rays", "100000", "--hostile-rays", "0",
                                  "--export-rays", "0", "--reps", "7", "--build-reps", "1", "--rep-seconds", "0.08",
                                  "--threads", "1", "--structures", "bvh", "--embree", "medium"]},
}
QUICK = {
    "meshes": [("goathead", "goathead.obj")],
    "native": ["--camera", "48x36", "--random-rays", "1500", "--hostile-rays", "1400", "--export-rays", "300",
               "--reps", "1",
               "--build-reps", "1", "--rep-seconds", "0.01", "--threads", "1,2", "--embree", "medium"],
    "blender_reps": 1,
    "thesis": {"width": 32, "height": 24, "super_sampling": [1, 2], "reps": 1, "reference_ss": 4},
    "leaks": {"meshes": ["goathead"], "rays_per_kind": 1000, "reps": 1},
    "self_hits": {"scales": [1e-3, 1, 1e5], "width": 24, "height": 18},
    "animation": {"mesh": "bunny_hr", "frames": 24, "camera": 96, "random_rays": 10000, "reps": 5},
    "builders": {"meshes": ["goathead"], "camera": 64, "random_rays": 5000, "reps": 1},
    "render": {"rounds": 2, "scenes": [("demo", 80, 60, [1, 2], 1)]},
    "api": {"reps": 3, "native": ["--cpu-time", "--camera", "96x72", "--random-rays", "5000", "--hostile-rays", "0",
                                  "--export-rays", "0", "--reps", "3", "--build-reps", "1", "--rep-seconds", "0.01",
                                  "--threads", "1", "--structures", "bvh", "--embree", "medium"]},
}


def log(*args):
    print("bench:", *args, flush=True)
