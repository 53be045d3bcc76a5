"""scene.raylab: what the viewport overlays and the ray probe show.

The probe's status fields are read-only: their getters return the probe's last evaluation (and
evaluate it first when the probe, the objects or the settings changed since), so a level's task
checker always reads what the viewport shows.
"""
import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatVectorProperty, FloatProperty, IntProperty,
                       PointerProperty, StringProperty)

STRUCTURE_ITEMS = [
    ("aabb", "AABB", "The object's axis-aligned bounding box, re-computed in world space as the object moves"),
    ("octree", "Octree", "The octree: a cube split into octants down to the maximum depth"),
    ("grid", "Grid", "The uniform grid: its non-empty cells (the resolution follows the triangle count)"),
    ("bvh", "BVH", "The bounding volume hierarchy (binned SAH)"),
]

VRT_GREEN = (0.2, 1.0, 0.2, 1.0)


def _redraw(self, context):
    """Overlay settings only change what is drawn: ask every 3D viewport to redraw."""
    for window in getattr(context.window_manager, "windows", []):
        for area in window.screen.areas:
            if area.type == 'VIEW_3D':
                area.tag_redraw()


def _depth_min_changed(self, context):
    if self.depth_max < self.depth_min:
        self.depth_max = self.depth_min
    _redraw(self, context)


def _depth_max_changed(self, context):
    if self.depth_min > self.depth_max:
        self.depth_min = self.depth_max
    _redraw(self, context)


def _spin_changed(self, context):
    from . import overlay
    overlay.update_spin_timer()
    _redraw(self, context)


def _probe_field(name):
    def get(self):
        from . import probe
        return probe.current_result(self.id_data)[name]
    return get


class RAYLAB_PG_scene(bpy.types.PropertyGroup):
    # Structure overlay
    structure: EnumProperty(name="Structure", items=STRUCTURE_ITEMS, default="octree", update=_redraw,
                            description="The acceleration structure drawn over the meshes and probed by the ray")
    max_depth: IntProperty(name="Max depth", min=0, max=10, default=4, update=_redraw,
                           description="Octree: the deepest level a node may split to (0 = the root alone)")
    leaf_size: IntProperty(name="Leaf size", min=1, max=64, default=8, update=_redraw,
                           description="Triangles a node may hold before it splits (octree) / per leaf (BVH)")
    show: BoolProperty(name="Show boxes", default=True, update=_redraw,
                       description="Draw the structure's boxes over the meshes")
    objects: EnumProperty(name="Objects", default="ALL", update=_redraw, items=[
        ("ALL", "All", "Every visible mesh object"),
        ("SELECTED", "Selected", "Only the selected mesh objects"),
    ], description="Which mesh objects get a structure (drawn and probed)")
    color_by_depth: BoolProperty(name="Colour by depth", default=False, update=_redraw,
                                 description="One colour per depth instead of the line colour")
    depth_min: IntProperty(name="Depth from", min=0, max=64, default=0, update=_depth_min_changed,
                           description="Draw only boxes at this depth or deeper")
    depth_max: IntProperty(name="Depth to", min=0, max=64, default=64, update=_depth_max_changed,
                           description="Draw only boxes at this depth or shallower")
    leaves_only: BoolProperty(name="Leaves only", default=False, update=_redraw,
                              description="Draw only the leaves (the boxes that hold triangles)")
    xray: BoolProperty(name="X-ray", default=False, update=_redraw,
                       description="Draw the boxes and the probe on top of everything (no depth test)")
    fade: BoolProperty(name="Fade", default=True, update=_redraw,
                       description="Deeper boxes, and boxes of dense structures, are drawn fainter")
    line_color: FloatVectorProperty(name="Line colour", subtype="COLOR", size=4, min=0.0, max=1.0,
                                    default=VRT_GREEN, update=_redraw,
                                    description="The boxes' colour when not coloured by depth")
    spin: BoolProperty(name="Spin", default=False, update=_spin_changed,
                       description="Rotate the shown mesh objects about Z on every frame change and "
                                   "on a timer, to watch the boxes follow")

    # Ray probe
    probe_enabled: BoolProperty(name="Ray probe", default=False, update=_redraw,
                                description="Trace one ray through the structure and show its story")
    probe_source: EnumProperty(name="Source", default="OBJECT", update=_redraw, items=[
        ("OBJECT", "Object", "From the probe object's origin along its local -Z axis (as lights and cameras)"),
        ("CAMERA", "Camera", "From the scene camera through the chosen pixel"),
    ])
    probe_object: PointerProperty(name="Ray object", type=bpy.types.Object, update=_redraw,
                                  description="The ray starts at this object's origin and goes along its "
                                              "local -Z axis (an Empty 'Single Arrow' points along +Z: "
                                              "the ray leaves from its base, opposite to the arrow)")
    probe_pixel_x: IntProperty(name="Pixel X", min=0, default=960, update=_redraw,
                               description="Camera source: the pixel column, from the left")
    probe_pixel_y: IntProperty(name="Pixel Y", min=0, default=540, update=_redraw,
                               description="Camera source: the pixel row, from the top")
    probe_length: FloatProperty(name="Ray length", min=0.01, default=20.0, subtype="DISTANCE", update=_redraw,
                                description="How far the ray is drawn when it hits nothing")
    fan_enabled: BoolProperty(name="Fan", default=False, update=_redraw,
                              description="Also trace N×N rays (the camera's frame, or a 40° pyramid around "
                                          "the ray object), coloured by what happened to each")
    fan_size: IntProperty(name="Fan size", min=1, max=64, default=8, update=_redraw,
                          description="N: the fan traces N×N rays")

    probe_status: StringProperty(name="Probe status", get=_probe_field("status"),
                                 description="missed_root, missed_nodes, missed_triangles, hit_object, "
                                             "or empty when there is no probe ray")
    probe_triangles_tested: IntProperty(name="Triangles tested", get=_probe_field("triangles_tested"))
    probe_boxes_tested: IntProperty(name="Boxes tested", get=_probe_field("boxes_tested"))
    probe_nodes_visited: IntProperty(name="Nodes visited", get=_probe_field("nodes_visited"))


CLASSES = (RAYLAB_PG_scene,)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.raylab = PointerProperty(type=RAYLAB_PG_scene)


def unregister():
    del bpy.types.Scene.raylab
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
