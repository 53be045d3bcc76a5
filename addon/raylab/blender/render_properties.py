"""scene.raylab_render: the settings of the raylab render engine and of the structure comparison."""
import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty

from .. import api
from .properties import structure_items


class RaylabRenderSettings(bpy.types.PropertyGroup):
    structure: EnumProperty(name="Structure", items=structure_items(), default=api.DEFAULTS["structure"],
                            description="Acceleration structure built for every mesh")
    max_depth: IntProperty(name="Octree Depth", default=api.DEFAULTS["max_depth"], min=0,
                           max=api.DEFAULTS["max_depth_limit"], soft_max=12,
                           description="Maximum octree depth (0 = the root box only)")
    leaf_size: IntProperty(name="Leaf Size", default=api.DEFAULTS["leaf_size"], min=1, max=256,
                           description="Triangles a node may hold before it is split (octree and BVH)")
    super_sampling: IntProperty(name="Super Sampling", default=1, min=1, max=4,
                                description="N x N camera rays per pixel")
    max_recursion: IntProperty(name="Max Recursion", default=3, min=0, max=16,
                               description="Reflection and refraction bounces")
    shadows: BoolProperty(name="Shadows", default=True, description="Trace shadow rays to the lights")
    robust_offset: BoolProperty(
        name="Robust Offset", default=True,
        description="Start secondary rays from an offset in integer ulps along the normal; "
                    "off uses a fixed epsilon of 1e-4 (shows shadow acne at large scales)")
    shadow_terminator: BoolProperty(
        name="Shadow Terminator", default=True,
        description="Smooth-shaded surfaces: shadow rays start from the curved surface the normals imply "
                    "(Hanika 2021), so the light's edge follows the smooth shading, not the facets")
    tile_size: IntProperty(name="Tile Size", default=32, min=8, max=512,
                           description="Pixels per side of a render tile")


def register():
    bpy.utils.register_class(RaylabRenderSettings)
    bpy.types.Scene.raylab_render = bpy.props.PointerProperty(type=RaylabRenderSettings)


def unregister():
    del bpy.types.Scene.raylab_render
    bpy.utils.unregister_class(RaylabRenderSettings)
