"""A fuzz pass over raylab's Python API: hostile meshes and rays, every structure against brute force, and
mutated OBJ files against the loader.

    /usr/bin/python3 tools/fuzz.py [--seconds 60] [--seed 1] [--out out/fuzz]

`./raylab test` runs it for about a minute with a fixed seed; `./raylab fuzz` runs it longer with a new seed
(and the libFuzzer harnesses of native/fuzz/). Each round builds a mesh of one hostile kind (a soup of random
triangles at a random scale and offset, a flattened sphere, a grid of shared edges, degenerate triangles, a
shipped mesh under a random affine map, collinear or sorted triangles that make the deepest trees, nested
clusters), at times scaled by 1e-30 to 1e30, with random settings, traces rays of hostile kinds (near-surface
origins, rays at vertices and edges, axis-parallel and denormal directions, tmax just past the hit), and
checks the contract (README, "Exactness and its limits"): with the watertight test aabb, octree and bvh return
brute force's closest hit and any-hit answer; with either test no hit has a t outside (tmin, tmax] or a non-
finite t; the fast contract's closest and any hit agree. float64 arrays past float32's range under -W error
raise a ValueError naming the array. Mutated OBJ files (indices past 2^31 and 2^32, numbers of hundreds of
digits, bytes that are not UTF-8) must load as a valid mesh or raise ValueError/OSError naming the file;
special files (a FIFO, /dev/zero, a directory) must be refused at once, naming the path. Odd threads= values
give one thread's answers or a ValueError naming threads. Renders of every structure are cancelled at random
moments (a progress callback that returns True after a random number of calls, or an event another thread
sets): each must return, say cancelled exactly when some pixel is left unrendered (zero alpha), count the
primary rays of the rendered pixels alone, and hold finite pixels. A crash ends the process, which is a
failure too. Every finding is printed with the seed and round that reproduce it, and the rounds' counts go to
out/fuzz/summary.json.
"""
import argparse
import json
import math
import os
import signal
import sys
import tempfile
import threading
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.environ.get("RAYLAB_ADDON_DIR", os.path.join(ROOT, "addon")))
import raylab  # noqa: E402

MESH_DIR = os.path.join(ROOT, "addon", "raylab", "meshes")
ACCELERATED = tuple(s for s in raylab.STRUCTURES if s != "none")  # each held to brute force
TINY_COMPONENTS = (0.0, -0.0, 1e-45, -1e-45, 1e-39, -1e-39, 1e-30, -1e-30)


# --- meshes --------------------------------------------------------------------------------------------

def soup(rng):
    n = int(rng.integers(1, 300))
    scale = 10.0 ** rng.uniform(-3, 5)
    offset = rng.normal(size=3) * 10.0 ** rng.uniform(-2, 5)
    vertices = rng.uniform(-1, 1, size=(3 * n, 3)) * scale + offset
    return vertices, np.arange(3 * n, dtype=np.uint32).reshape(n, 3)


def grid(rng):
    """Quads split into two triangles: every inner edge is shared, every inner vertex by six triangles."""
    side = int(rng.integers(2, 24))
    x, y = np.meshgrid(np.linspace(-1, 1, side + 1), np.linspace(-1, 1, side + 1))
    z = np.zeros_like(x) if rng.random() < 0.5 else rng.uniform(-0.2, 0.2, size=x.shape)
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3) * 10.0 ** rng.uniform(-2, 3)
    i = np.arange(side)[:, None] * (side + 1) + np.arange(side)[None, :]
    a, b, c, d = i, i + 1, i + side + 1, i + side + 2
    triangles = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])
    return vertices, triangles.astype(np.uint32)


def shipped(rng, name=None):
    name = name or str(rng.choice(["sphere", "spot_low_resolution", "plane_holes", "goathead"]))
    vertices, triangles = raylab.load_mesh(os.path.join(MESH_DIR, f"{name}.obj"))
    matrix = np.linalg.qr(rng.normal(size=(3, 3)))[0] * (10.0 ** rng.uniform(-2, 3, size=3))
    return vertices.astype(np.float64) @ matrix.T + rng.normal(size=3) * 10.0 ** rng.uniform(-1, 4), triangles


def flattened(rng):
    """A closed mesh squashed flat (z scaled by 0 or almost 0): two layers of triangles in one plane."""
    vertices, triangles = raylab.load_mesh(os.path.join(MESH_DIR, "sphere.obj"))
    vertices = vertices.astype(np.float64) * [1.0, 1.0, float(rng.choice([0.0, 1e-7, 1e-4]))]
    return vertices, triangles


def degenerate(rng):
    vertices, triangles = soup(rng)
    n = len(triangles)
    pick = rng.random(n) < 0.3
    # Collinear corners (zero area) and repeated corners.
    vertices[triangles[pick, 2]] = 0.5 * (vertices[triangles[pick, 0]] + vertices[triangles[pick, 1]])
    repeat = rng.random(n) < 0.1
    vertices[triangles[repeat, 1]] = vertices[triangles[repeat, 0]]
    return vertices, triangles


def collinear(rng):
    """Triangles of consecutive points sorted along a line, some a hair off it: boxes of zero or almost
    zero area, which tie in the SAH and in the wide collapse and make the deepest trees."""
    n = 3 * int(rng.integers(100, 3000))
    direction = unit(rng.normal(size=3))
    along = np.sort(rng.uniform(0, 1, n)) if rng.random() < 0.7 else rng.uniform(0, 1, n)
    vertices = along[:, None] * direction
    off = rng.random(n) < float(rng.choice([0.0, 0.05, 0.5]))
    vertices[off] += rng.normal(size=(int(off.sum()), 3)) * 10.0 ** rng.uniform(-9, -3)
    return vertices, np.arange(n, dtype=np.uint32).reshape(-1, 3)


def clustered(rng):
    """Clusters of small triangles whose sizes span many orders of magnitude, nested in one another."""
    clusters = int(rng.integers(2, 12))
    parts = []
    for k in range(clusters):
        size = 10.0 ** -float(rng.uniform(0, 6 + 2 * k))
        centre = rng.normal(size=3) * size * 10
        parts.append(rng.normal(size=(3 * int(rng.integers(3, 80)), 3)) * size + centre)
    vertices = np.concatenate(parts)
    return vertices, np.arange(len(vertices), dtype=np.uint32).reshape(-1, 3)


MESHES = {"soup": soup, "grid": grid, "shipped": shipped, "flattened": flattened, "degenerate": degenerate,
          "collinear": collinear, "clustered": clustered}
# Each mesh at a random scale at times, within the coordinate limit or past it (refused at build).
SCALE_EXPONENTS = (-30, 30)


# --- rays ----------------------------------------------------------------------------------------------

def unit(v):
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(length > 0, length, 1.0)


def triangle_points(vertices, triangles, rng, n, where="inside"):
    t = rng.integers(0, len(triangles), n)
    a, b, c = (vertices[triangles[t, k]] for k in range(3))
    if where == "vertex":
        return a
    if where == "edge":
        s = rng.random((n, 1))
        return a + s * (b - a)
    u, v = rng.random((n, 1)), rng.random((n, 1))
    flip = (u + v) > 1
    u, v = np.where(flip, 1 - u, u), np.where(flip, 1 - v, v)
    return a + u * (b - a) + v * (c - a)


def rays(vertices, triangles, rng, n):
    """(origins, directions, kind) of n rays in float64; each kind aimed at a weakness."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    size = max(float(np.max(hi - lo)), 1e-30)
    centre = (lo + hi) / 2
    k = n // 6
    groups = []
    # Random origins around the box, random directions.
    groups.append(("random", centre + rng.uniform(-1, 1, (k, 3)) * size, unit(rng.normal(size=(k, 3)))))
    # From outside at vertices, edges and inner points.
    for where in ("vertex", "edge", "inside"):
        targets = triangle_points(vertices, triangles, rng, k, where)
        origins = centre + unit(rng.normal(size=(k, 3))) * size * 2
        groups.append((f"at_{where}", origins, targets - origins))
    # Just above a surface, leaving in any direction (secondary rays).
    t = rng.integers(0, len(triangles), k)
    a, b, c = (vertices[triangles[t, m]] for m in range(3))
    normal = unit(np.cross(b - a, c - a))
    lift = (10.0 ** rng.uniform(-9, -3, (k, 1))) * size * rng.choice([-1.0, 1.0], (k, 1))
    groups.append(("near_surface", triangle_points(vertices, triangles, rng, k) + normal * lift,
                   unit(rng.normal(size=(k, 3)))))
    # Axis-parallel and tiny or denormal components, from the box's centre planes (octree splits).
    directions = np.zeros((k, 3))
    axis = rng.integers(0, 3, k)
    directions[np.arange(k), axis] = rng.choice([-1.0, 1.0], k)
    for other in range(3):
        tiny = rng.choice(TINY_COMPONENTS, k)
        directions[:, other] = np.where(axis == other, directions[:, other], tiny)
    origins = centre + rng.uniform(-1, 1, (k, 3)) * size
    plane = rng.integers(0, 3, k)
    origins[np.arange(k), plane] = centre[plane]
    groups.append(("axis_tiny", origins - directions * size * 2, directions))
    origins = np.concatenate([g[1] for g in groups])
    directions = np.concatenate([g[2] for g in groups])
    kinds = np.concatenate([[g[0]] * len(g[1]) for g in groups])
    return origins, directions, kinds


# --- the contract --------------------------------------------------------------------------------------

class Findings:
    def __init__(self, seed):
        self.seed, self.items = seed, []

    def add(self, round_, what):
        self.items.append(f"seed {self.seed} round {round_}: {what}")
        if len(self.items) <= 30:  # the first ones in full; the rest go to the summary only
            print(f"fuzz: FINDING seed {self.seed} round {round_}: {what}", flush=True)


def check_hits(hits, tmin, tmax):
    """Indices of hits that break the contract on t: finite, in (tmin, tmax]."""
    t = hits.t
    bad = hits.hit & ~(np.isfinite(t) & (t > tmin) & (t <= tmax))
    return np.flatnonzero(bad)


def compare(name, got, expected, kinds):
    differs = (got.hit != expected.hit) | (got.hit & (got.triangle != expected.triangle)
                                           & ~(got.t == expected.t))
    differs |= got.hit & expected.hit & ~np.isclose(got.t, expected.t, rtol=1e-5, atol=0.0)
    i = np.flatnonzero(differs)
    if len(i) == 0:
        return None
    j = i[0]
    by_kind = {str(k): int((kinds[i] == k).sum()) for k in np.unique(kinds[i])}
    return (f"{name}: {len(i)} rays differ from brute force {by_kind}; first ray {j} ({kinds[j]}): "
            f"hit {got.hit[j]} triangle {got.triangle[j]} t {got.t[j]!r}, brute force hit {expected.hit[j]} "
            f"triangle {expected.triangle[j]} t {expected.t[j]!r}")


def trace_round(rng, round_, findings, counts):
    kind = str(rng.choice(list(MESHES)))
    vertices, triangles = MESHES[kind](rng)
    if rng.random() < 0.25:
        vertices = vertices * 10.0 ** rng.uniform(*SCALE_EXPONENTS)
    vertices32 = np.asarray(vertices, np.float32)
    if not np.isfinite(vertices32).all():
        return
    test = "moller_trumbore" if rng.random() < 0.25 else "watertight"
    depth = "auto" if rng.random() < 0.3 else int(rng.integers(0, 9))  # "auto": the octree's default
    settings = dict(max_depth=depth, leaf_size=int(rng.integers(1, 17)), triangle_test=test)
    builder = str(rng.choice(raylab.BUILDERS))  # the BVH's; the kinds without one build their one way
    try:
        structures = {s: raylab.build(vertices32, triangles, structure=s, **settings,
                                      **({"builder": builder} if raylab.STRUCTURE_INFO[s]["uses_builder"] else {}))
                      for s in ("none", *ACCELERATED)}
    except ValueError as error:  # the contract's refusals (e.g. coordinates too large) are fine
        counts["refused_builds"] += 1
        if "Traceback" in str(error) or len(str(error)) > 400:
            findings.add(round_, f"unreadable build error on {kind}: {str(error)[:200]}")
        return
    except raylab.BuildError:
        counts["refused_builds"] += 1
        return
    counts["builds"] += 4
    origins, directions, kinds = rays(vertices32.astype(np.float64), triangles, rng, 1800)
    origins, directions = origins.astype(np.float32), directions.astype(np.float32)
    finite = (np.isfinite(origins).all(axis=1) & np.isfinite(directions).all(axis=1)
              & (np.abs(directions).max(axis=1) > 0))
    origins, directions, kinds = origins[finite], directions[finite], kinds[finite]
    tmin = float(rng.choice([0.0, 0.0, 1e-6, 1e-3]))
    reference = structures["none"].intersect(origins, directions, tmin=tmin)
    reference_any = structures["none"].occluded(origins, directions, tmin=tmin)
    counts["rays"] += len(origins) * 4
    for name, structure in structures.items():
        hits = structure.intersect(origins, directions, tmin=tmin)
        bad = check_hits(hits, tmin, math.inf)
        if len(bad):
            findings.add(round_, f"{name} ({test}) on {kind}: {len(bad)} hits with t outside ({tmin}, inf] or "
                                 f"not finite, e.g. t {hits.t[bad[0]]!r}")
        # Möller–Trumbore is the leaky teaching option: only its t range is part of the contract.
        if name == "none" or test == "moller_trumbore":
            continue
        problem = compare(f"{name} ({test}, {settings}, builder {structure.builder}) on {kind}", hits, reference,
                          kinds)
        if problem:
            findings.add(round_, problem)
        occluded = structure.occluded(origins, directions, tmin=tmin).hit
        if not np.array_equal(occluded, reference_any.hit):
            findings.add(round_, f"{name} ({test}) on {kind}: any-hit differs from brute force on "
                                 f"{int((occluded != reference_any.hit).sum())} rays")
    # The fast contract promises less than brute force's hits, but its closest and any hit never disagree.
    try:
        fast = raylab.build(vertices32, triangles, contract="fast", builder=builder)
    except (ValueError, raylab.BuildError):
        fast = None
    if fast is not None:
        hit = fast.intersect(origins, directions, tmin=tmin).hit
        if not np.array_equal(fast.occluded(origins, directions, tmin=tmin).hit, hit):
            findings.add(round_, f"bvh (fast, builder {builder}) on {kind}: closest and any hit disagree on "
                                 f"{int((fast.occluded(origins, directions, tmin=tmin).hit != hit).sum())} rays")
        counts["rays"] += 2 * len(origins)
    # tmax just past brute force's hit (the shadow ray to a light on the surface): one call per ray.
    hit = np.flatnonzero(reference.hit & np.isfinite(reference.t)) if test == "watertight" else []
    for i in rng.choice(hit, min(len(hit), 40), replace=False) if len(hit) else []:
        tmax = float(reference.t[i]) * (1 + float(rng.choice([1e-6, 1e-7, 0.0])))
        for name in ACCELERATED:
            got = structures[name].intersect(origins[i], directions[i], tmin=tmin, tmax=tmax)
            if not got.hit[0] or got.t[0] != reference.t[i]:
                findings.add(round_, f"{name} ({test}) on {kind}: ray {i} ({kinds[i]}) with tmax {tmax!r} just "
                                     f"past brute force's t {reference.t[i]!r} gives hit {got.hit[0]} t {got.t[0]!r}")
            if not structures[name].occluded(origins[i], directions[i], tmin=tmin, tmax=tmax).hit[0]:
                findings.add(round_, f"{name} ({test}) on {kind}: ray {i} occluded misses with tmax just past the hit")
        counts["rays"] += 2 * len(ACCELERATED)


# --- float64 input ------------------------------------------------------------------------------------

def float64_round(rng, round_, findings, counts):
    """float64 arrays past float32's range under `-W error` (the warning fails numpy's conversion): each
    entry raises a ValueError naming the array, never a crash."""
    import warnings
    vertices = np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    triangles = np.uint32([[0, 1, 2]])
    huge = np.zeros((int(rng.integers(1, 5)), 3)) + float(rng.choice([1e39, 1e300, -3.5e38]))
    structure = raylab.build(vertices, triangles)
    scene = raylab.Scene()
    mesh = scene.add_mesh(vertices, triangles)
    calls = {"origins": lambda: structure.intersect(huge, [0, 0, -1]),
             "directions": lambda: structure.occluded([0, 0, 1], huge),
             "vertices": lambda: scene.replace_mesh(mesh, huge[:1].repeat(3, axis=0), triangles)}
    for name, call in calls.items():
        with warnings.catch_warnings(), np.errstate(all="warn"):
            warnings.simplefilter("error")
            try:
                call()
                findings.add(round_, f"float64 {name} past float32's range under -W error was accepted")
            except ValueError as error:
                if not str(error).startswith(name):
                    findings.add(round_, f"float64 {name} under -W error: the error does not name it: {error}")
        counts["float64_calls"] += 1


# --- threads= -------------------------------------------------------------------------------------------

# What a caller may pass as threads=: the accepted give the answers of one thread, whatever the
# machine's cores; the others a ValueError naming threads, never a crash.
THREADS_ACCEPTED = [None, 0, 1, 2, 3, 7, 64, 65536, 65537, 100000, 2**31 - 1, np.int64(5), np.uint8(2)]
THREADS_REFUSED = [-1, -2**31, 2**31, 2**63, 2.0, "2", True, [2], np.float32(1)]


def threads_round(rng, round_, findings, counts):
    vertices, triangles = MESHES["shipped"](rng)
    try:
        structure = raylab.build(np.asarray(vertices, np.float32), triangles,
                                 structure=str(rng.choice(["none", *ACCELERATED])))
    except ValueError:  # the contract's refusals, counted in trace_round
        return
    origins, directions, _ = rays(np.asarray(vertices, np.float64), triangles, rng, 300)
    origins, directions = origins.astype(np.float32), directions.astype(np.float32)
    one = structure.intersect(origins, directions, threads=1)
    for threads in [THREADS_ACCEPTED[i] for i in rng.choice(len(THREADS_ACCEPTED), 3, replace=False)]:
        got = structure.intersect(origins, directions, threads=threads)
        if not (np.array_equal(got.t, one.t) and np.array_equal(got.triangle, one.triangle)):
            findings.add(round_, f"intersect with threads={threads!r} differs from one thread")
        counts["rays"] += len(origins)
    threads = THREADS_REFUSED[int(rng.integers(0, len(THREADS_REFUSED)))]
    query = str(rng.choice(["intersect", "occluded", "statuses"]))
    try:
        getattr(structure, query)(origins, directions, threads=threads)
        findings.add(round_, f"{query} accepted threads={threads!r}")
    except ValueError as error:
        if "threads" not in str(error):
            findings.add(round_, f"{query} with threads={threads!r}: the error does not name threads: {error}")


# --- OBJ files -----------------------------------------------------------------------------------------

OBJ_BASE = """# a cube of quads with texture coordinates and normals, and a triangle with negative indices
v -1 -1 -1
v 1 -1 -1
v 1 1 -1
v -1 1 -1
v -1 -1 1
v 1 -1 1
v 1 1 1
v -1 1 1
vt 0 0
vt 1 0
vt 1 1
vn 0 0 -1
f 1/1/1 2/2/1 3/3/1 4/3/1
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
v 0 0 3
v 1 0 3
v 0 1 3
f -3 -2 -1
"""
OBJ_TOKENS = ["nan", "inf", "-inf", "1e39", "-1e39", "1e-46", "a", "1,5", "", "0x10", "-0", "1e", "+", "f", "v",
              "//", "/", "-1", "0", "99999999999999999999", "-99", "3.4e38", "1e308", "\t", "#", "\\", "vn", "o x",
              # indices that wrap round 2^31 and 2^32 onto a vertex of the file
              "2147483648", "2147483650", "4294967297", "4294967296", "8589934595", "-4294967295", "-2147483649",
              "4294967297/1/1", "1//4294967297",
              # numbers longer than a float parser's buffer: 0.1 and 1.0
              "0." + "0" * 400 + "1e400", "1" + "0" * 400 + "e-400", "1" * 500]
# Bytes that are not UTF-8, put into a line: the message must still be a str naming the file.
OBJ_BYTES = [b"\xff", b"\xfe\xff", b"\xc3", b"\xed\xa0\x80", b"\x80", b"\x00", b"\xf4\x90\x80\x80"]


# --- cancelled renders ---------------------------------------------------------------------------------

def look_from(eye, target):
    """Camera-to-world matrix of a camera at `eye` looking at `target` (down its local -Z)."""
    back = unit(eye - target)
    up = np.array([0.0, 0.0, 1.0]) if abs(back[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    right = unit(np.cross(up, back))
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, np.cross(back, right), back, eye
    return m


def cancel_round(rng, round_, findings, counts):
    structure = str(rng.choice(raylab.STRUCTURES))
    vertices, triangles = shipped(rng)
    vertices = np.asarray(vertices, np.float32)
    lo, hi = vertices.min(axis=0).astype(np.float64), vertices.max(axis=0).astype(np.float64)
    centre, size = (lo + hi) / 2, max(float(np.linalg.norm(hi - lo)), 1e-3)
    try:
        scene = raylab.Scene(structure=structure)
        scene.add_instance(scene.add_mesh(vertices, triangles), np.eye(4), material=0)
        scene.commit()
    except (ValueError, raylab.BuildError):
        counts["refused_builds"] += 1
        return
    eye = centre + unit(rng.normal(size=3)) * size * rng.uniform(1.0, 3.0)
    width, height = (int(x) for x in rng.integers(8, 160, size=2))
    camera = dict(type=str(rng.choice(["PERSP", "ORTHO"])), matrix_world=look_from(eye, centre), ortho_scale=size,
                  resolution_x=width, resolution_y=height, clip_start=1e-3 * size, clip_end=10.0 * size)
    lights = [dict(type=str(rng.choice(["POINT", "SUN", "SPOT", "AREA"])), energy=100.0 * size * size,
                   matrix_world=look_from(eye, centre), size=0.3 * size)]
    materials = [dict(reflectivity=float(rng.uniform(0, 1)), transmission=float(rng.uniform(0, 1)))]
    ss = int(rng.integers(1, 5))
    settings = dict(super_sampling=ss, tile_size=int(rng.choice([1, 7, 32, 4096])),
                    max_recursion=int(rng.integers(0, 5)), threads=int(rng.integers(0, 3)))
    stop = threading.Event()
    if rng.random() < 0.5:
        calls, after = [0], int(rng.integers(0, 4))  # the first call comes before any pixel

        def progress(fraction):
            calls[0] += 1
            return calls[0] > after
    else:
        threading.Timer(float(rng.uniform(0.0, 0.3)), stop.set).start()

        def progress(fraction):
            return stop.is_set()
    try:
        result = raylab.render(scene, camera, lights, materials, settings, progress=progress)
    except Exception as error:  # noqa: BLE001 - whatever it is, a cancel must not cause it
        findings.add(round_, f"a cancelled {structure} render raised {type(error).__name__}: {error}")
        return
    finally:
        stop.set()
    counts["renders"] += 1
    counts["cancelled_renders"] += bool(result.cancelled)
    alpha = result.image[..., 3]
    rendered = int((alpha == 1.0).sum())
    what = f"{structure} {width}x{height} ss {ss} {settings}"
    if result.cancelled != bool((alpha == 0.0).any()) or rendered + int((alpha == 0.0).sum()) != alpha.size:
        findings.add(round_, f"cancelled={result.cancelled} with {rendered} of {alpha.size} pixels rendered: {what}")
    if result.stats["rays_primary"] != ss * ss * rendered:
        findings.add(round_, f"{result.stats['rays_primary']} primary rays for {rendered} pixels at ss {ss}: {what}")
    if not np.isfinite(result.image).all():
        findings.add(round_, f"a cancelled render has non-finite pixels: {what}")


def mutate(text, rng):
    lines = text.split("\n")
    for _ in range(int(rng.integers(1, 4))):
        if not lines:
            lines = [""]
        op = rng.integers(0, 5)
        i = int(rng.integers(0, len(lines)))
        tokens = lines[i].split(" ")
        if op == 0:  # replace a token
            tokens[int(rng.integers(0, len(tokens)))] = str(rng.choice(OBJ_TOKENS))
            lines[i] = " ".join(tokens)
        elif op == 1:  # drop a token
            if len(tokens) > 1:
                del tokens[int(rng.integers(0, len(tokens)))]
            lines[i] = " ".join(tokens)
        elif op == 2:  # delete or duplicate a line
            lines.insert(i, lines[i]) if rng.random() < 0.5 else lines.pop(i)
        elif op == 3:  # a random byte
            if lines[i]:
                j = int(rng.integers(0, len(lines[i])))
                lines[i] = lines[i][:j] + chr(int(rng.integers(1, 256))) + lines[i][j + 1:]
        else:  # truncate
            lines = lines[:i + 1]
            lines[i] = lines[i][:int(rng.integers(0, len(lines[i]) + 1))]
    return "\n".join(lines)


def obj_round(rng, round_, findings, counts, folder):
    path = os.path.join(folder, "mutated.obj")
    data = mutate(OBJ_BASE, rng).encode("latin-1")
    if rng.random() < 0.2:  # raw bytes into a line
        at = int(rng.integers(0, len(data) + 1))
        data = data[:at] + OBJ_BYTES[int(rng.integers(0, len(OBJ_BYTES)))] + data[at:]
    text = data.decode("latin-1")
    with open(path, "wb") as file:
        file.write(data)
    counts["obj_files"] += 1
    try:
        vertices, triangles = raylab.load_mesh(path)
    except (ValueError, OSError) as error:
        counts["obj_refused"] += 1
        if path not in str(error):
            findings.add(round_, f"load_mesh refused without naming the file: {type(error).__name__}({str(error)!r}) "
                                 f"on:\n{text!r}")
        return
    except Exception as error:  # anything else is not the loader's contract
        findings.add(round_, f"load_mesh raised {type(error).__name__}: {error} on:\n{text}")
        return
    if not np.isfinite(vertices).all() or (len(triangles) and triangles.max() >= len(vertices)):
        findings.add(round_, f"load_mesh returned a mesh with non-finite vertices or bad indices from:\n{text}")


class Hang(Exception):
    pass


def raise_hang(*_):
    raise Hang()


def special_file_round(round_, findings, counts, folder):
    """A FIFO, a device that never ends, a directory: a clear ValueError/OSError naming the path, at once
    (an alarm ends a read that blocks or runs on)."""
    fifo = os.path.join(folder, "fifo.obj")
    if not os.path.exists(fifo):
        os.mkfifo(fifo)
    for path in (fifo, "/dev/zero", folder):
        counts["special_files"] += 1
        previous = signal.signal(signal.SIGALRM, raise_hang)
        signal.alarm(10)
        try:
            raylab.load_mesh(path)
            findings.add(round_, f"load_mesh loaded {path}")
        except (ValueError, OSError) as error:
            if path not in str(error):
                findings.add(round_, f"load_mesh refused {path} without naming it: {error!r}")
        except Hang:
            findings.add(round_, f"load_mesh did not return within 10 s on {path}")
        finally:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, previous)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--seed", type=int, default=None, help="default: a new one, printed")
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "fuzz"))
    args = parser.parse_args()
    seed = args.seed if args.seed is not None else int.from_bytes(os.urandom(4), "little")
    print(f"fuzz: seed {seed}, {args.seconds:.0f} s", flush=True)
    findings = Findings(seed)
    counts = dict(rounds=0, builds=0, refused_builds=0, rays=0, obj_files=0, obj_refused=0, special_files=0,
                  renders=0, cancelled_renders=0, float64_calls=0)
    started = time.monotonic()
    with tempfile.TemporaryDirectory() as folder, np.errstate(all="ignore"):
        round_ = 0
        while time.monotonic() - started < args.seconds:
            rng = np.random.default_rng([seed, round_])  # each round reproducible on its own
            trace_round(rng, round_, findings, counts)
            threads_round(rng, round_, findings, counts)
            float64_round(rng, round_, findings, counts)
            cancel_round(rng, round_, findings, counts)
            for _ in range(20):
                obj_round(rng, round_, findings, counts, folder)
            special_file_round(round_, findings, counts, folder)
            round_ += 1
            counts["rounds"] = round_
    os.makedirs(args.out, exist_ok=True)
    summary = dict(seed=seed, seconds=time.monotonic() - started, counts=counts, findings=findings.items)
    with open(os.path.join(args.out, "summary.json"), "w") as file:
        json.dump(summary, file, indent=2)
    print(f"fuzz: {counts['rounds']} rounds, {counts['builds']:,} builds ({counts['refused_builds']} refused), "
          f"{counts['rays']:,} rays, {counts['obj_files']:,} mutated OBJ files ({counts['obj_refused']:,} refused), "
          f"{counts['special_files']:,} special files, "
          f"{counts['renders']} renders cancelled at random ({counts['cancelled_renders']} before the end): "
          f"{len(findings.items)} findings")
    sys.exit(1 if findings.items else 0)


if __name__ == "__main__":
    main()
