"""Every difference between the Blender releases raylab supports (3.4, and 4.2 and later), in one place.

Each helper asks Blender whether a feature is there rather than comparing version numbers, so a release
in between (or a future one that keeps an API) takes the right branch by itself.
"""
import math

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


# --- 5.0: materials and worlds always use their node trees ---------------------------------------------
# `use_nodes` of materials and worlds does nothing since 5.0 and warns on every read and write (removal
# in 6.0). Whether it still means something is a release fact, not a property to probe: reading it is
# what warns.
def nodes_always():
    import bpy
    return bpy.app.version >= (5, 0)


def node_tree(idblock):
    """The node tree a material or world shades with, or None where it shades without nodes."""
    if nodes_always() or idblock.use_nodes:
        return idblock.node_tree
    return None


def use_node_tree(idblock):
    """Makes a material or world shade with its node tree (a no-op since 5.0) and returns the tree."""
    if not nodes_always():
        idblock.use_nodes = True
    return idblock.node_tree


def set_world_colour(world, colour):
    """A plain background colour (linear RGB) as every release renders it: the Background node's colour at
    strength 1 (since 5.0 the only way: a world without nodes is gone), and the world's viewport colour."""
    world.color = colour
    background = next(node for node in use_node_tree(world).nodes if node.type == 'BACKGROUND')
    background.inputs["Color"].default_value = (*colour, 1.0)
    background.inputs["Strength"].default_value = 1.0


# --- 5.0: the file format of a multilayer EXR, and the compositor's node group --------------------------

def set_file_format(image_settings, file_format):
    """Render output as `file_format` ('PNG', 'OPEN_EXR', ... or 'OPEN_EXR_MULTILAYER', one file of every
    pass). 5.0 put a media type over the format: a multilayer EXR is the multilayer media type's only
    format, and the single-layer ones belong to the image media type, so the type is set first."""
    if "media_type" in image_settings.bl_rna.properties:
        image_settings.media_type = 'MULTI_LAYER_IMAGE' if file_format == 'OPEN_EXR_MULTILAYER' else 'IMAGE'
    image_settings.file_format = file_format


def compositor_tree(scene):
    """The scene's compositor node tree, made when missing: 5.0 turned Scene.node_tree (with use_nodes) into
    a node group of its own, Scene.compositing_node_group, which starts empty."""
    import bpy
    if hasattr(scene, "compositing_node_group"):
        if scene.compositing_node_group is None:
            scene.compositing_node_group = bpy.data.node_groups.new("Compositor", 'CompositorNodeTree')
        return scene.compositing_node_group
    scene.use_nodes = True
    return scene.node_tree


def remove_compositor(scene):
    """Turns the scene's compositing off again (5.x: unassigns and deletes its node group)."""
    import bpy
    if hasattr(scene, "compositing_node_group"):
        group = scene.compositing_node_group
        if group is not None:
            scene.compositing_node_group = None
            bpy.data.node_groups.remove(group)
    else:
        scene.use_nodes = False


def render_layers_node(scene):
    """The compositor's Render Layers node (added when the tree has none)."""
    tree = compositor_tree(scene)
    node = next((n for n in tree.nodes if n.type == 'R_LAYERS'), None)
    return node if node is not None else tree.nodes.new('CompositorNodeRLayers')


# --- 4.5: a light's power with exposure and normalize ---------------------------------------------------

def light_power(light):
    """The power the renderer gives a light, as Cycles and EEVEE read it: energy times 2^exposure (4.5+),
    and for an area light whose Normalize is off (4.5+) times its area (the energy is then per square
    metre: the light grows brighter with its size)."""
    power = float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))
    if light.type == 'AREA' and not getattr(light, "normalize", True):
        if light.shape in ('SQUARE', 'DISK'):
            width = height = light.size
        else:
            width, height = light.size, light.size_y
        area = width * height * (math.pi / 4 if light.shape in ('DISK', 'ELLIPSE') else 1.0)
        power *= area
    return power


# --- 5.0: each file's working colour space ---------------------------------------------------------------
# Linear Rec.709 primaries to each working space's (D65; ACEScg's AP1 through a Bradford adaptation to
# its D60 white): raylab's fixed colours (the heat colour map, its legend) are defined in Rec.709.
REC709_TO = {
    "Linear Rec.709": None,
    "Linear Rec.2020": np.array([[0.627404, 0.329283, 0.043313],
                                 [0.069097, 0.919540, 0.011362],
                                 [0.016391, 0.088013, 0.895595]]),
    "ACEScg": np.array([[0.613097, 0.339523, 0.047379],
                        [0.070194, 0.916354, 0.013452],
                        [0.020616, 0.109570, 0.869815]]),
}


def working_space():
    """The file's working colour space ("Linear Rec.709" before 5.0, which had no other)."""
    import bpy
    colorspace = getattr(bpy.data, "colorspace", None)
    return getattr(colorspace, "working_space", "Linear Rec.709")


def rec709_to_working(rgba):
    """(..., 3|4) linear Rec.709 colours in the file's working space (alpha kept); a space raylab has no
    matrix for is a ValueError that names it."""
    space = working_space()
    if space not in REC709_TO:
        raise ValueError(f"raylab has no conversion to the working colour space {space!r}")
    matrix = REC709_TO[space]
    if matrix is None:
        return rgba
    out = np.array(rgba, np.float32, copy=True)
    out[..., :3] = out[..., :3] @ matrix.T.astype(np.float32)
    return out
