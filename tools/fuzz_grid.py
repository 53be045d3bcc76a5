"""A fuzz pass aimed at the grid's weak spots: the grid against brute force, bit for bit (triangle, t, u,
v, and the any-hit answer), on hostile meshes and rays.

    /usr/bin/python3 tools/fuzz_grid.py [--seconds 180] [--seed 1]

Meshes: random soups and degenerate soups (collinear and repeated corners) at random scales and
offsets, a shipped mesh under a random affine map, flat and almost flat meshes, quads split into
triangles whose edges lie on the grid's own cell planes, a single triangle. Rays: from just above or
below a surface, grazing (in a triangle's plane, plus a hair), at vertices and edges, axis-parallel with
the origin on cell planes and corners (read from boxes()) with tiny, denormal or -0 other components,
origins inside the grid, and shadow-ray intervals ending exactly at the hit (tmax = t, one float
before, tmin one float before). tools/fuzz.py checks every structure more loosely; this one is exact.
"""
import argparse
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.environ.get("RAYLAB_ADDON_DIR", os.path.join(ROOT, "addon")))
import raylab  # noqa: E402

MESH_DIR = os.path.join(ROOT, "addon", "raylab", "meshes")
TINY = (0.0, -0.0, 1e-45, -1e-45, 1e-39, -1e-39, 1e-30, -1e-30, -1e-20)


def unit(v):
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(length > 0, length, 1.0)


# --- meshes ----------------------------------------------------------------------------------------------

def soup(rng):
    n = int(rng.integers(1, 400))
    scale = 10.0 ** rng.uniform(-3, 5)
    centres = rng.uniform(-1, 1, (n, 1, 3)) * scale
    sizes = (10.0 ** rng.uniform(-3, 0, (n, 1, 1))) * scale
    vertices = (centres + rng.normal(size=(n, 3, 3)) * sizes).reshape(-1, 3) + rng.normal(size=3) * scale
    return vertices, np.arange(3 * n, dtype=np.uint32).reshape(n, 3)


def degenerate(rng):
    vertices, triangles = soup(rng)
    pick = rng.random(len(triangles)) < 0.3
    vertices[triangles[pick, 2]] = 0.5 * (vertices[triangles[pick, 0]] + vertices[triangles[pick, 1]])
    repeat = rng.random(len(triangles)) < 0.1
    vertices[triangles[repeat, 1]] = vertices[triangles[repeat, 0]]
    return vertices, triangles


def shipped(rng):
    name = str(rng.choice(["sphere", "spot_low_resolution", "goathead", "plane_holes", "bunny"]))
    vertices, triangles = raylab.load_mesh(os.path.join(MESH_DIR, f"{name}.obj"))
    matrix = np.linalg.qr(rng.normal(size=(3, 3)))[0] * (10.0 ** rng.uniform(-2, 3, size=3))
    return vertices.astype(np.float64) @ matrix.T + rng.normal(size=3) * 10.0 ** rng.uniform(-1, 4), triangles


def flat(rng):
    vertices, triangles = raylab.load_mesh(os.path.join(MESH_DIR, "sphere.obj"))
    vertices = vertices.astype(np.float64) * [1.0, 1.0, float(rng.choice([0.0, 1e-7, 1e-4]))]
    if rng.random() < 0.5:  # a flat mesh not aligned with an axis
        vertices = vertices @ np.linalg.qr(rng.normal(size=(3, 3)))[0].T
    return vertices, triangles


def quads(rng):
    """A side x side grid of quads on [0, 1]^2 (z = 0 or a second layer at z = 1): with side a
    multiple of the grid's cells, its edges and vertices lie on cell planes."""
    side = int(rng.choice([3, 4, 6, 8, 12, 16]))
    x, y = np.meshgrid(np.linspace(0, 1, side + 1), np.linspace(0, 1, side + 1))
    layers = [np.stack([x, y, np.full_like(x, z)], -1).reshape(-1, 3) for z in ((0.0,) if rng.random() < 0.5 else (0.0, 1.0))]
    vertices = np.concatenate(layers)
    i = np.arange(side)[:, None] * (side + 1) + np.arange(side)[None, :]
    tri = np.concatenate([np.stack([i, i + 1, i + side + 2], -1).reshape(-1, 3),
                          np.stack([i, i + side + 2, i + side + 1], -1).reshape(-1, 3)])
    triangles = np.concatenate([tri + k * (side + 1) ** 2 for k in range(len(layers))])
    return vertices * 10.0 ** rng.uniform(-2, 3), triangles.astype(np.uint32)


def single(rng):
    return rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-2, 3), np.array([[0, 1, 2]], np.uint32)


MESHES = {"soup": soup, "degenerate": degenerate, "shipped": shipped, "flat": flat, "quads": quads,
          "single": single}


# --- rays ------------------------------------------------------------------------------------------------

def surface_points(vertices, triangles, rng, n):
    t = rng.integers(0, len(triangles), n)
    a, b, c = (vertices[triangles[t, k]] for k in range(3))
    u, v = rng.random((n, 1)), rng.random((n, 1))
    flip = (u + v) > 1
    u, v = np.where(flip, 1 - u, u), np.where(flip, 1 - v, v)
    return a + u * (b - a) + v * (c - a), a, b, c


def cell_planes(structure):
    """Per axis, every cell plane of the grid (from the non-empty cells' boxes and the bounds)."""
    b = structure.boxes()
    return [np.unique(np.concatenate([b["lo"][:, k], b["hi"][:, k]])) for k in range(3)]


def make_rays(vertices, triangles, planes, rng, n):
    lo, hi = vertices.min(0), vertices.max(0)
    size = max(float(np.max(hi - lo)), 1e-30)
    centre = (lo + hi) / 2
    k = n // 6
    groups = []
    # Just above or below a surface (1e-9 to 1e-3 of the mesh size), in any direction.
    p, a, b, c = surface_points(vertices, triangles, rng, k)
    normal = unit(np.cross(b - a, c - a))
    lift = (10.0 ** rng.uniform(-9, -3, (k, 1))) * size * rng.choice([-1.0, 1.0], (k, 1))
    groups.append(("near_surface", p + normal * lift, unit(rng.normal(size=(k, 3)))))
    # Grazing: along a triangle's plane, plus a hair towards it, from a point near that plane.
    p, a, b, c = surface_points(vertices, triangles, rng, k)
    normal = unit(np.cross(b - a, c - a))
    along = unit(np.cross(normal, rng.normal(size=(k, 3))))
    hair = 10.0 ** rng.uniform(-8, -2, (k, 1)) * rng.choice([-1.0, 0.0, 1.0], (k, 1))
    groups.append(("grazing", p - along * size * rng.uniform(0.01, 2, (k, 1)) + normal * hair * size * 0.1,
                   along + normal * hair))
    # From around the mesh at vertices and edge points.
    _, a, b, _ = surface_points(vertices, triangles, rng, k)
    s = rng.choice([0.0, 0.5, 1.0, rng.random()], (k, 1))
    targets = a + s * (b - a)
    origins = centre + unit(rng.normal(size=(k, 3))) * size * rng.uniform(0.6, 3, (k, 1))
    groups.append(("at_vertex_edge", origins, targets - origins))
    # Axis-parallel, the other components tiny, denormal or -0, the origin on cell planes (a corner
    # of cells when all three are), outside or inside the grid.
    directions = np.zeros((k, 3))
    axis = rng.integers(0, 3, k)
    sign = rng.choice([-1.0, 1.0], k)
    directions[np.arange(k), axis] = sign
    for other in range(3):
        directions[:, other] = np.where(axis == other, directions[:, other], rng.choice(TINY, k))
    origins = np.stack([rng.choice(planes[m], k) for m in range(3)], 1)
    off_plane = rng.random((k, 3)) < 0.2
    origins = np.where(off_plane, centre + rng.uniform(-0.6, 0.6, (k, 3)) * size, origins)
    outside = rng.random(k) < 0.5
    start = np.where(sign > 0, lo[axis] - size, hi[axis] + size)
    origins[np.arange(k), axis] = np.where(outside, start, origins[np.arange(k), axis])
    groups.append(("axis_on_planes", origins, directions))
    # From inside the grid, in any direction, some with tiny components.
    directions = unit(rng.normal(size=(k, 3)))
    zero = rng.random((k, 3)) < 0.2
    directions = np.where(zero, rng.choice(TINY, (k, 3)), directions)
    directions[np.all(directions == 0, axis=1), 0] = 1.0
    groups.append(("inside", lo + rng.random((k, 3)) * (hi - lo), directions))
    # Random, from far away (large pads) and nearby.
    origins = centre + unit(rng.normal(size=(k, 3))) * size * 10.0 ** rng.uniform(-1, 4, (k, 1))
    groups.append(("far", origins, centre + rng.uniform(-0.5, 0.5, (k, 3)) * size - origins))
    origins = np.concatenate([g[1] for g in groups]).astype(np.float32)
    directions = np.concatenate([g[2] for g in groups]).astype(np.float32)
    kinds = np.concatenate([[g[0]] * len(g[1]) for g in groups])
    keep = np.all(np.isfinite(origins), 1) & np.all(np.isfinite(directions), 1) & np.any(directions != 0, 1)
    return origins[keep], directions[keep], kinds[keep]


# --- the comparison --------------------------------------------------------------------------------------

def differences(got, expected):
    same = (got.hit == expected.hit) & (~expected.hit | ((got.triangle == expected.triangle) & (got.t == expected.t)
                                                          & (got.u == expected.u) & (got.v == expected.v)))
    return np.flatnonzero(~same)


def fuzz_round(rng, round_, seed, counts, findings):
    kind = str(rng.choice(list(MESHES)))
    vertices, triangles = MESHES[kind](rng)
    vertices = vertices.astype(np.float32)
    if not np.all(np.isfinite(vertices)):
        return
    none = raylab.build(vertices, triangles, "none")
    grid = raylab.build(vertices, triangles, "grid")
    origins, directions, kinds = make_rays(vertices, triangles, cell_planes(grid), rng, 1200)
    tmin = float(rng.choice([0.0, 0.0, 1e-6, -1.0]))

    def report(what, bad, o, d, lo, hi):
        j = bad[0]
        findings.append(f"seed {seed} round {round_} ({kind}, {len(triangles)} triangles): {what}: {len(bad)} rays "
                        f"differ; first {kinds[j] if len(kinds) == len(o) else ''} origin {o[j].tolist()} direction "
                        f"{d[j].tolist()} tmin {lo} tmax {hi}")
        print("FINDING", findings[-1], flush=True)

    expected = none.intersect(origins, directions, tmin=tmin)
    bad = differences(grid.intersect(origins, directions, tmin=tmin), expected)
    if len(bad):
        report("closest", bad, origins, directions, tmin, "inf")
    counted = grid.intersect(origins, directions, tmin=tmin, count=True)
    bad = differences(counted, expected)
    if len(bad):
        report("closest (counting)", bad, origins, directions, tmin, "inf")
    occluded = none.occluded(origins, directions, tmin=tmin).hit
    bad = np.flatnonzero(grid.occluded(origins, directions, tmin=tmin).hit != occluded)
    if len(bad):
        report("any", bad, origins, directions, tmin, "inf")
    counts["rays"] += len(origins)
    counts["hits"] += int(expected.hit.sum())
    counts["by_kind"][kind] = counts["by_kind"].get(kind, 0) + len(origins)
    # Intervals ending at the hit, ray by ray: tmax = t, one float before t; tmin one float before t.
    hit = np.flatnonzero(expected.hit)
    for i in rng.choice(hit, min(len(hit), 60), replace=False) if len(hit) else []:
        t = np.float32(expected.t[i])
        for lo, hi in ((tmin, float(t)), (tmin, float(np.nextafter(t, np.float32(-np.inf)))),
                       (float(np.nextafter(t, np.float32(-np.inf))), float("inf"))):
            if not lo <= hi:
                continue
            e = none.intersect(origins[i], directions[i], tmin=lo, tmax=hi)
            g = grid.intersect(origins[i], directions[i], tmin=lo, tmax=hi)
            if len(differences(g, e)) or none.occluded(origins[i], directions[i], tmin=lo, tmax=hi).hit[0] != \
                    grid.occluded(origins[i], directions[i], tmin=lo, tmax=hi).hit[0]:
                report("interval at the hit", [0], origins[i:i + 1], directions[i:i + 1], lo, hi)
            counts["interval_rays"] += 1


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=180)
    parser.add_argument("--seed", type=int, default=int(time.time()) % 100000)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    counts = {"rounds": 0, "rays": 0, "hits": 0, "interval_rays": 0, "by_kind": {}}
    findings = []
    end = time.time() + args.seconds
    while time.time() < end:
        fuzz_round(rng, counts["rounds"], args.seed, counts, findings)
        counts["rounds"] += 1
    print(f"fuzz_grid: seed {args.seed}: {counts['rounds']} meshes, {counts['rays']} rays ({counts['hits']} hits) "
          f"x closest, counted closest and any; {counts['interval_rays']} intervals at the hit; rays by mesh "
          f"{counts['by_kind']}; {len(findings)} findings")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
