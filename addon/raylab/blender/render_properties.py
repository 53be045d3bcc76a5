"""scene.raylab_render: the settings of the raylab render engine and of the structure comparison."""
import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty

STRUCTURE_ITEMS = [
    ("none", "None", "Every ray tests every triangle"),
    ("aabb", "AABB", "One bounding box per object; rays that miss it are ignored"),
    ("octree", "Octree", "Octree per mesh (maximum depth, leaf size)"),
    ("grid", "Grid", "Uniform grid per mesh (about 3 * cbrt(triangles) cells along the longest axis)"),
    ("bvh", "BVH", "Bounding volume hierarchy per mesh (binned SAH)"),
]


class RaylabRenderSettings(bpy.types.PropertyGroup):
    structure: EnumProperty(name="Structure", items=STRUCTURE_ITEMS, default="bvh",
                            description="Acceleration structure built for every mesh")
    max_depth: IntProperty(name="Octree Depth", default=6, min=0, max=12,
                           description="Maximum octree depth (0 = the root box only)")
    leaf_size: IntProperty(name="Leaf Size", default=8, min=1, max=256,
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
