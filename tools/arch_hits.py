"""The same hits on every architecture, bit for bit (./raylab test --arch arm64).

    python3 tools/arch_hits.py write FILE.npz   on the host (x86-64): the rays and their hits
    python3 tools/arch_hits.py check FILE.npz   elsewhere (arm64 under qemu): the same rays traced again

The rays are tests/python/test_equivalence.py's (rays.mixed_rays, about 100k per mesh, every family where
naive methods fail), made once on the host and stored as float32: numpy's vectorised sin and cos differ
between architectures, the rays must not. Each mesh is traced by every structure, contract and BVH builder
(brute force on the equivalence suite's evenly spread subset), closest hit (uncounted and counted) and any
hit, and the check compares t, u, v, triangle, instance, hit and the counters as bits. Meshes: the shipped ones but the
four largest (minutes each under emulation: the equivalence suite leaves them to the host too).
"""
import argparse
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))  # conftest: the add-on (RAYLAB_ADDON_DIR) and the meshes
from conftest import MESHES, load  # noqa: E402
import raylab  # noqa: E402
from raylab import rays  # noqa: E402

SEED = 20261122  # test_equivalence.py's
LARGEST = ("dragon", "bunny_hr", "koala", "armadillo")
# test_equivalence.py's LARGE_MESH_RAYS: brute force (`none`, and `aabb` for rays entering the box) costs
# rays x triangles, so these trace an evenly spread subset.
BRUTE_FORCE = ("none", "aabb")
BRUTE_FORCE_RAYS = 2_500
HIT_FIELDS = ("t", "u", "v", "triangle", "instance", "hit")


def configurations():
    """(label, build keyword arguments) of every structure, contract and builder."""
    for structure in raylab.STRUCTURES:
        info = raylab.STRUCTURE_INFO[structure]
        for contract in raylab.CONTRACTS if info["uses_contract"] else ("exact",):
            for builder in raylab.BUILDERS if info["uses_builder"] else (raylab.DEFAULTS["builder"],):
                yield (f"{structure}/{contract}/{builder}",
                       dict(structure=structure, contract=contract, builder=builder))


def trace(name, origins, directions):
    """{key: array} of every configuration's answers on mesh `name`."""
    vertices, triangles = load(name)
    spread = np.linspace(0, len(origins) - 1, min(len(origins), BRUTE_FORCE_RAYS)).astype(np.int64)
    out = {}
    for label, kwargs in configurations():
        o, d = origins, directions
        if kwargs["structure"] in BRUTE_FORCE:
            o, d = o[spread], d[spread]
        s = raylab.build(vertices, triangles, **kwargs)
        key = f"{name}/{label}"
        # The uncounted queries (the renderer's path, coherent batches included) and the counting one (the
        # same traversal with another recorder, and its counters).
        counted = s.intersect(o, d, count=True)
        for query, hits in (("closest", s.intersect(o, d)), ("counted", counted)):
            for field in HIT_FIELDS:
                out[f"{key}/{query}/{field}"] = np.ascontiguousarray(getattr(hits, field))
        out[f"{key}/counted/stats"] = np.array([counted.stats[c] for c in raylab.COUNTERS], np.float64)
        out[f"{key}/any/hit"] = np.ascontiguousarray(s.occluded(o, d).hit)
    return out


def meshes():
    return [m for m in MESHES if m not in LARGEST]


def write(path):
    data = {}
    for name in meshes():
        vertices, triangles = load(name)
        origins, directions, _ = rays.mixed_rays(vertices, triangles, SEED)
        data[f"{name}/rays/origins"], data[f"{name}/rays/directions"] = origins, directions
        data.update(trace(name, origins, directions))
        print(f"{name}: {len(origins)} rays traced")
    np.savez_compressed(path, **data)


def check(path):
    stored = np.load(path)
    names = sorted({key.split("/")[0] for key in stored.files})
    assert names == meshes(), f"{path} holds meshes {names}, this checkout ships {meshes()}"
    rays_compared = hits_compared = 0
    differ = []
    for name in names:
        start = time.time()
        got = trace(name, stored[f"{name}/rays/origins"], stored[f"{name}/rays/directions"])
        expected_keys = {k for k in stored.files if not k.startswith(f"{name}/rays/") and k.startswith(f"{name}/")}
        assert set(got) == expected_keys, f"{name}: configurations differ from the file's"
        for key, value in got.items():
            want = stored[key]
            # Bits, not values: -0 and +0, and NaN payloads, count too.
            if value.dtype != want.dtype or value.shape != want.shape or value.tobytes() != want.tobytes():
                differ.append(key)
            if key.endswith("/closest/t"):
                rays_compared += len(value)
                hits_compared += int(got[key[:-1] + "hit"].sum())
        print(f"{name}: {len(got)} arrays compared ({time.time() - start:.0f} s)")
    print(f"{rays_compared} ray queries (closest and any hit each) on {len(names)} meshes, "
          f"{hits_compared} closest hits: {len(differ)} arrays differ")
    for key in differ:
        print(f"  differs: {key}")
    return 1 if differ else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("write", "check"))
    parser.add_argument("file", type=pathlib.Path)
    args = parser.parse_args()
    if args.action == "write":
        write(args.file)
        return 0
    return check(args.file)


if __name__ == "__main__":
    sys.exit(main())
