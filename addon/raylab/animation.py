"""Animations of a mesh in numpy, for refit experiments and tests: a deforming mesh, as an armature or a
Wave modifier would make it, without Blender.

    from raylab import animation
    V, T = raylab.load_mesh(path)
    s = raylab.build(V, T)
    for frame in range(48):
        s = s.refit(animation.twist_wave(V, frame, 48))      # or raylab.build(..., T) to rebuild

Only numpy is needed (like raylab.rays).
"""
import numpy as np


def twist_wave(vertices, frame, frames, twist=1.5, wave=0.1):
    """The (V,3) float32 vertices of frame `frame` of `frames`: the mesh twisted about the z axis
    through its box's centre, by up to `twist` radians across its size at the last frame, and a
    travelling wave along x that moves it in y by up to `wave` times its size. Frame 0 has the wave
    alone. The topology never changes; triangles stretch, shear and, where the twist is strong, tilt
    far from the pose the structure was built for, which is what degrades a refitted tree."""
    v = np.asarray(vertices, np.float64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    centre, size = (lo + hi) / 2, float(np.max(hi - lo)) or 1.0
    p = v - centre
    angle = twist * frame / max(frames - 1, 1) * (p[:, 2] / size)
    c, s = np.cos(angle), np.sin(angle)
    x, y = p[:, 0] * c - p[:, 1] * s, p[:, 0] * s + p[:, 1] * c
    y = y + wave * size * np.sin(6.0 * x / size + 0.5 * frame)
    return np.ascontiguousarray(np.stack([x, y, p[:, 2]], axis=1) + centre, np.float32)
