"""Every difference between the Blender releases raylab supports (3.4, and 4.2 and later), in one place.

Each helper asks Blender whether a feature is there rather than comparing version numbers, so a release
in between (or a future one that keeps an API) takes the right branch by itself.
"""
import numpy as np

# Principled BSDF inputs renamed in 4.0: the new name first, then the 3.x one.
PRINCIPLED_INPUTS = {
    "specular": ("Specular IOR Level", "Specular"),
    "transmission": ("Transmission Weight", "Transmission"),
}


def principled_value(node, key):
    """The default value of a Principled BSDF input by raylab's key ("specular", "transmission")."""
    for name in PRINCIPLED_INPUTS[key]:
        socket = node.inputs.get(name)
        if socket is not None:
            return socket.default_value
    raise KeyError(f"Principled BSDF has none of the inputs {PRINCIPLED_INPUTS[key]}")


def smooth_by_angle(mesh, angle):
    """Shade Smooth with edges sharper than `angle` (radians) kept sharp, as auto smooth did before 4.1.

    4.1 removed auto smooth: the sharp edges are then written into the mesh (what Shade Auto Smooth and
    Smooth by Angle do for an unmodified mesh). The polygons must exist; the caller marks them smooth."""
    if hasattr(mesh, "use_auto_smooth"):
        mesh.use_auto_smooth = True
        mesh.auto_smooth_angle = angle
    else:
        mesh.set_sharp_from_angle(angle=angle)


def corner_normals(mesh):
    """(L,3) float32 normal of every face corner (loop) as Blender shades it: Shade Smooth, Flat and sharp
    edges, custom normals included. 4.1+ computes them on demand (Mesh.corner_normals); 3.x needs
    calc_normals_split() first, which is then read from the loops."""
    normals = np.empty(len(mesh.loops) * 3, np.float32)
    if hasattr(mesh, "corner_normals"):
        mesh.corner_normals.foreach_get("vector", normals)
    else:
        mesh.calc_normals_split()
        mesh.loops.foreach_get("normal", normals)
    return normals.reshape(-1, 3)


def set_pass_pixels(render_pass, pixels):
    """Fills a render result pass from its pixels, bottom row first: (H, W, C), (N, C) or, for a
    1-channel pass, (H, W) float32. 4.x's foreach_set wants the N*C numbers flat, 3.x's one row of C per
    pixel; both report the other shape as a TypeError before writing anything (and len(rect) is N on
    both, so it cannot tell them apart)."""
    pixels = np.ascontiguousarray(pixels, np.float32).reshape(-1, render_pass.channels)
    try:
        render_pass.rect.foreach_set(pixels.ravel())
    except TypeError:
        render_pass.rect.foreach_set(pixels)


def update_render_passes(view_layer):
    """Asks the render engine again which passes the View Layer delivers (after raylab's pass settings
    changed), where the release has ViewLayer.update_render_passes."""
    update = getattr(view_layer, "update_render_passes", None)
    if update is not None:
        update()
