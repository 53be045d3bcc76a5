"""Ray sets for testing and measuring structures: the rays of raylab's own equivalence and watertightness
tests, for scripting experiments with the same rays.

    from raylab import rays
    V, T = raylab.load_mesh(path)
    rng = np.random.default_rng(1)
    origins, directions = rays.camera_rays(V, 256)          # a 256x256 pinhole camera framing the mesh
    origins, directions = rays.grazing_rays(V, T, 10000, rng)
    origins, directions, family = rays.mixed_rays(V, T, seed=1)   # every family below, about 100k rays
    h = raylab.build(V, T).intersect(origins, directions)

The ray generators return (origins, directions) as (N,3) float32 arrays, ready for intersect(); the
random ones draw from the numpy Generator they are given, so a seed reproduces them. Directions are
not always unit length (aimed rays point at their target). Only numpy is needed: the module works
without the native core, and in Blender it is loaded on first use, not when the add-on registers.
"""
import numpy as np


def bounds(vertices):
    """The mesh's bounding box as two float64 corners (lo, hi)."""
    lo, hi = vertices.min(axis=0).astype(np.float64), vertices.max(axis=0).astype(np.float64)
    return lo, hi


def _f32(origins, directions):
    return np.ascontiguousarray(origins, np.float32), np.ascontiguousarray(directions, np.float32)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_directions(rng, n):
    """n unit vectors uniform on the sphere (float64)."""
    return _unit(rng.normal(size=(n, 3)))


def camera_rays(vertices, side, view=(0.3, 0.4, 1.0)):
    """A pinhole camera looking at the mesh's centre from `view`, side x side pixels framing the mesh."""
    lo, hi = bounds(vertices)
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    back = _unit(np.asarray(view, np.float64))
    eye = centre + 3.0 * radius * back
    right = _unit(np.cross([0.0, 1.0, 0.0], back))
    up = np.cross(back, right)
    half = np.tan(np.arcsin(1.0 / 3.0)) * 1.05  # the bounding sphere fills the frame
    s = (np.arange(side) + 0.5) / side * 2 - 1
    x, y = np.meshgrid(s * half, s * half)
    directions = -back + x.reshape(-1, 1) * right + y.reshape(-1, 1) * up
    return _f32(np.broadcast_to(eye, directions.shape), directions)


def random_rays(vertices, n, rng):
    """Origins uniform in the bounding box enlarged by half its size on each side; random directions."""
    lo, hi = bounds(vertices)
    size = hi - lo
    origins = rng.uniform(lo - 0.5 * size, hi + 0.5 * size, size=(n, 3))
    return _f32(origins, random_directions(rng, n))


def outside_points(vertices, n, rng):
    """Points on a sphere twice the size of the bounding sphere: surely outside the mesh."""
    lo, hi = bounds(vertices)
    return (lo + hi) / 2 + np.linalg.norm(hi - lo) * random_directions(rng, n)


def edge_points(vertices, triangles, n, rng, where=None):
    """Points on triangle edges: at the midpoint, or (where=None) at a random place along the edge."""
    tri = triangles[rng.integers(0, len(triangles), n)]
    corner = rng.integers(0, 3, n)
    a = vertices[tri[np.arange(n), corner]].astype(np.float64)
    b = vertices[tri[np.arange(n), (corner + 1) % 3]].astype(np.float64)
    s = np.full((n, 1), where) if where is not None else rng.uniform(0.0, 1.0, (n, 1))
    return a + s * (b - a)


def aimed_rays(origins, targets):
    """Rays from `origins` through `targets`."""
    return _f32(origins, targets - origins)


def vertex_rays(vertices, triangles, n, rng):
    """Rays from outside the mesh aimed exactly at its vertices."""
    targets = vertices[rng.integers(0, len(vertices), n)].astype(np.float64)
    return aimed_rays(outside_points(vertices, n, rng), targets)


def edge_midpoint_rays(vertices, triangles, n, rng):
    """Rays from outside the mesh aimed exactly at edge midpoints."""
    return aimed_rays(outside_points(vertices, n, rng), edge_points(vertices, triangles, n, rng, where=0.5))


def split_planes(vertices, levels=3):
    """Per axis: the bounding-box faces and centre, and the mid-planes of an octree over the box grown
    to a cube (the root cube and its subdivisions down to `levels`)."""
    lo, hi = bounds(vertices)
    centre, half = (lo + hi) / 2, (hi - lo).max() / 2
    planes = []
    for axis in range(3):
        cube_lo = centre[axis] - half
        cuts = np.arange(1, 2 ** levels) / 2 ** levels * 2 * half + cube_lo
        planes.append(np.unique(np.concatenate([[lo[axis], hi[axis], centre[axis]], cuts])).astype(np.float32))
    return planes


def axis_rays(vertices, n, rng):
    """Axis-parallel rays from outside the box, with the other two origin coordinates chosen among the
    split planes (one or both exactly on a plane), in both directions along each axis."""
    lo, hi = bounds(vertices)
    planes = split_planes(vertices)
    axis = rng.integers(0, 3, n)
    sign = rng.choice([-1.0, 1.0], n)
    origins = rng.uniform(lo, hi, (n, 3))
    on_plane = rng.integers(1, 4, n)  # bit 0: first other axis on a plane; bit 1: second
    for i in range(n):
        a = axis[i]
        for bit, b in enumerate(((a + 1) % 3, (a + 2) % 3)):
            if on_plane[i] >> bit & 1:
                origins[i, b] = rng.choice(planes[b])
        origins[i, a] = lo[a] - 1.0 - (hi[a] - lo[a]) if sign[i] > 0 else hi[a] + 1.0 + (hi[a] - lo[a])
    directions = np.zeros((n, 3))
    directions[np.arange(n), axis] = sign
    return _f32(origins, directions)


def triangle_frames(vertices, triangles, index):
    """Centroids and unit normals of triangles `index` (degenerate triangles give NaN normals)."""
    p = vertices[triangles[index]].astype(np.float64)
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        normal = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    return p.mean(axis=1), normal


def _proper(vertices, triangles, n, rng):
    index = rng.integers(0, len(triangles), 2 * n)
    centroid, normal = triangle_frames(vertices, triangles, index)
    keep = np.isfinite(normal).all(axis=1)
    return centroid[keep][:n], normal[keep][:n]


def grazing_rays(vertices, triangles, n, rng):
    """Rays nearly parallel to a triangle's plane (1e-2 to 1e-6 rad off it) through its centroid."""
    centroid, normal = _proper(vertices, triangles, n, rng)
    m = len(centroid)
    in_plane = _unit(np.cross(normal, random_directions(rng, m)))
    tilt = 10.0 ** rng.uniform(-6, -2, (m, 1)) * rng.choice([-1.0, 1.0], (m, 1))
    directions = _unit(in_plane + tilt * normal)
    lo, hi = bounds(vertices)
    return _f32(centroid - np.linalg.norm(hi - lo) * directions, directions)


def inside_rays(vertices, triangles, n, rng):
    """Rays starting inside the mesh: just behind faces (along the inward normal for a consistently
    oriented closed mesh), exactly on faces, and at the centre of the bounding box; random directions."""
    centroid, normal = _proper(vertices, triangles, n, rng)
    m = len(centroid)
    lo, hi = bounds(vertices)
    depth = np.linalg.norm(hi - lo) * 10.0 ** rng.uniform(-6, -2, (m, 1))
    origins = centroid - depth * normal
    origins[: m // 4] = centroid[: m // 4]
    origins[m // 4 : m // 3] = (lo + hi) / 2
    return _f32(origins, random_directions(rng, m))


# The ray families of the equivalence tests, by name.
FAMILIES = {
    "random": lambda v, t, n, rng: random_rays(v, n, rng),
    "vertex": vertex_rays,
    "edge_midpoint": edge_midpoint_rays,
    "axis": lambda v, t, n, rng: axis_rays(v, n, rng),
    "grazing": grazing_rays,
    "inside": inside_rays,
}


def mixed_rays(vertices, triangles, seed, camera_side=160, per_family=13000):
    """About 100k rays: a camera grid plus every family of FAMILIES. Returns origins, directions and
    the family name of each ray."""
    rng = np.random.default_rng(seed)
    sets = {"camera": camera_rays(vertices, camera_side)}
    sets.update((name, make(vertices, triangles, per_family, rng)) for name, make in FAMILIES.items())
    family = np.concatenate([np.full(len(o), name) for name, (o, _) in sets.items()])
    return (np.concatenate([o for o, _ in sets.values()]), np.concatenate([d for _, d in sets.values()]), family)
