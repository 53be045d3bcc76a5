"""The add-on's settings, one property group per scene attribute: scene.raylab (what the viewport
overlays and the ray probe show) and scene.raylab_render (the render engine and the comparison).

The probe's status fields are read-only: their getters return the probe's last evaluation (and
evaluate it first when the probe, the objects or the settings changed since), so a level's task
checker always reads what the viewport shows.

The properties sit below the features they drive: the probe and the spin timer hand their entry points
in through `features` when they register, so nothing here imports them back.
"""
import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatVectorProperty, FloatProperty, IntProperty,
                       PointerProperty, StringProperty)

from .. import api
from . import draw


def work_counter_items():
    """The counters a structure's traversal counts per ray (box tests, triangle tests, nodes visited)."""
    return [(name, info["label"], info["description"]) for name, info in api.COUNTER_INFO.items()
            if info["object_work"]]


def structure_items(drawable_only=False):
    """EnumProperty items from the core's table of structure kinds (api.STRUCTURE_INFO)."""
    return [(name, info["label"], info["description"]) for name, info in api.STRUCTURE_INFO.items()
            if info["has_boxes"] or not drawable_only]


def contract_items():
    """EnumProperty items from the core's table of contracts (api.CONTRACT_INFO): exact, fast."""
    return [(name, info["label"], info["description"]) for name, info in api.CONTRACT_INFO.items()]


def builder_items():
    """EnumProperty items from the core's table of BVH builders (api.BUILDER_INFO): sah, median, ..."""
    return [(name, info["label"], info["description"]) for name, info in api.BUILDER_INFO.items()]


def structure_properties(*, drawable_only, structure, max_depth, auto_depth, update=None):
    """The structure and its build settings (build_settings.py reads them), defined once for both groups so
    that their limits cannot drift: a mix-in class of the six properties. `drawable_only`: no kind
    without boxes (the overlay's list); `structure`, `max_depth`, `auto_depth`: the defaults; `update`:
    what a change calls."""
    on_change = {} if update is None else {"update": update}
    return type("StructureProperties", (), {"__annotations__": {
        "structure": EnumProperty(name="Structure", items=structure_items(drawable_only), default=structure,
                                  description="The acceleration structure built for every shown mesh",
                                  **on_change),
        "max_depth_auto": BoolProperty(
            name="Auto depth", default=auto_depth, **on_change,
            description="Octree: choose the depth from the triangle count and the memory budget (a node "
                        "still stops splitting at the leaf size); off: the depth below"),
        "max_depth": IntProperty(name="Max depth", min=0, max=api.DEFAULTS["max_depth_limit"], soft_max=12,
                                 default=max_depth, **on_change,
                                 description="Octree: the deepest level a node may split to when Auto depth "
                                             "is off (0 = the root box alone)"),
        "leaf_size": IntProperty(name="Leaf size", min=1, max=256, default=api.DEFAULTS["leaf_size"], **on_change,
                                 description="Triangles a node may hold before it splits (octree) / per leaf "
                                             "(BVH)"),
        "contract": EnumProperty(name="Contract", items=contract_items(), default=api.DEFAULTS["contract"],
                                 **on_change,
                                 description="BVH: what a hit promises. Exact: the same hit as brute force; "
                                             "fast: Embree's tests, faster, wrong at edges and near surfaces"),
        "builder": EnumProperty(name="Builder", items=builder_items(), default=api.DEFAULTS["builder"],
                                **on_change,
                                description="BVH: where each node splits. The binned SAH minimises the expected "
                                            "cost of a ray; the others split by count, by space or by Morton "
                                            "code"),
    }})


class _Features:
    """The entry points of the features the properties drive, handed in by their register()."""
    probe_result = None   # probe.current_result: scene -> the probe's fields
    spin_changed = None   # spin.update_spin_timer


features = _Features()


VRT_GREEN = (0.2, 1.0, 0.2, 1.0)


def _redraw(self, context):
    """Overlay settings only change what is drawn: ask every 3D viewport to redraw."""
    draw.tag_redraw(context)


def _depth_min_changed(self, context):
    if self.depth_max < self.depth_min:
        self.depth_max = self.depth_min
    _redraw(self, context)


def _depth_max_changed(self, context):
    if self.depth_min > self.depth_max:
        self.depth_min = self.depth_max
    _redraw(self, context)


def _spin_changed(self, context):
    if features.spin_changed is not None:
        features.spin_changed()
    _redraw(self, context)


def _probe_field(name, unregistered):
    def get(self):
        read = features.probe_result
        return unregistered if read is None else read(self.id_data)[name]
    return get


def _probe_counter(counter):
    """A read-only count of the probe's ray, named as the core's counter (api.COUNTER_INFO)."""
    info = api.COUNTER_INFO[counter]
    return IntProperty(name=info["label"], get=_probe_field(counter, 0),
                       description=f"The probe's ray: {info['description'][0].lower()}{info['description'][1:]}")


def _image_size(scene):
    """The render's pixels, as Blender and raylab's camera count them (integer division: no float
    rounding puts 29 % of 100 pixels at 28)."""
    render = scene.render
    return (render.resolution_x * render.resolution_percentage // 100,
            render.resolution_y * render.resolution_percentage // 100)


_PIXEL_KEYS = ("probe_pixel_x_set", "probe_pixel_y_set")  # the ID properties holding what was set


def _pixel_getter(axis):
    """The probe's pixel derives from the scene's image: its centre until set, and clamped into the
    image (a pixel outside it gives no camera ray)."""
    def get(self):
        size = _image_size(self.id_data)[axis]
        return min(max(int(self.get(_PIXEL_KEYS[axis], size // 2)), 0), max(size - 1, 0))
    return get


def _pixel_setter(axis):
    def set(self, value):
        self[_PIXEL_KEYS[axis]] = value
    return set


# The viewport starts shallower than F12, a depth-4 octree can be read box by box, and Auto depth is off
# there: the levels teach with the depth slider.
class RAYLAB_PG_scene(structure_properties(drawable_only=True, structure="octree", max_depth=4, auto_depth=False,
                                           update=_redraw), bpy.types.PropertyGroup):
    # Structure overlay: structure, max_depth_auto, max_depth, leaf_size, contract, builder from structure_properties
    animation_update: EnumProperty(name="On animation", default="REFIT", update=_redraw, items=[
        ("REFIT", "Refit", "Keep the structure's tree and recompute its boxes: fast, but the tree degrades "
                           "(octree and grid rebuild anyway)"),
        ("REBUILD", "Rebuild", "Build the structure anew from the moved mesh: slower, the best tree every frame"),
    ], description="What the structure of a deforming mesh (armature, modifiers, shape keys) does when its "
                   "geometry changes, e.g. on each frame of an animation")
    # Off in a user's own files (the Preferences can turn it on there); every level turns it on itself.
    show: BoolProperty(name="Show boxes", default=False, update=_redraw,
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

    # Cost heat map (cost_overlay.py)
    cost_enabled: BoolProperty(name="Cost heat map", default=False, update=_redraw,
                               description="Colour the 3D view by what a ray from each spot of it costs the "
                                           "structure (traced at low resolution as the view moves)")
    cost_counter: EnumProperty(name="Count", items=work_counter_items(), default="triangle_tests", update=_redraw,
                               description="The work per ray the heat map shows")
    cost_maximum: IntProperty(name="Scale maximum", min=1, soft_max=1000, default=64, update=_redraw,
                              description="The count drawn in the hottest colour: a fixed scale, so that the "
                                          "same colour means the same count for every structure")
    cost_cells: IntProperty(name="Cells across", min=8, max=320, default=96, update=_redraw,
                            description="Columns of the heat map's grid (square cells): one ray each")

    # Ray probe
    probe_enabled: BoolProperty(name="Ray probe", default=False, update=_redraw,
                                description="Trace one ray through the structure and show its story")
    probe_source: EnumProperty(name="Source", default="OBJECT", update=_redraw,
                               description="Where the probe's ray comes from", items=[
                                   ("OBJECT", "Object",
                                    "From the ray object's origin along its local +Z axis, where its arrow points"),
                                   ("CAMERA", "Camera", "From the scene camera through the chosen pixel")])
    probe_object: PointerProperty(name="Ray object", type=bpy.types.Object, update=_redraw,
                                  description="The ray starts at this object's origin and goes along its "
                                              "local +Z axis, where an Empty 'Single Arrow' points")
    probe_pixel_x: IntProperty(name="Pixel X", min=0, get=_pixel_getter(0), set=_pixel_setter(0), update=_redraw,
                               description="Camera source: the pixel column, from the left (the image's "
                                           "centre until set; kept inside the image)")
    probe_pixel_y: IntProperty(name="Pixel Y", min=0, get=_pixel_getter(1), set=_pixel_setter(1), update=_redraw,
                               description="Camera source: the pixel row, from the top (the image's centre "
                                           "until set; kept inside the image)")
    probe_length: FloatProperty(name="Ray length", min=0.01, default=20.0, subtype="DISTANCE", update=_redraw,
                                description="How far the ray is drawn when it hits nothing")
    fan_enabled: BoolProperty(name="Fan", default=False, update=_redraw,
                              description="Also trace N×N rays (the camera's frame, or a 40° pyramid around "
                                          "the ray object), coloured by what happened to each")
    fan_size: IntProperty(name="Fan size", min=1, max=64, default=8, update=_redraw,
                          description="N: the fan traces N×N rays")

    probe_status: StringProperty(name="Probe status", get=_probe_field("status", ""),
                                 description="missed_root, missed_nodes, missed_triangles, hit_object, "
                                             "or empty when there is no probe ray")
    probe_triangle_tests: _probe_counter("triangle_tests")
    probe_box_tests: _probe_counter("box_tests")
    probe_nodes_visited: _probe_counter("nodes_visited")


class RAYLAB_PG_render(structure_properties(drawable_only=False, structure=api.DEFAULTS["structure"], max_depth=6,
                                            auto_depth=api.DEFAULTS["max_depth"] == "auto"),
                       bpy.types.PropertyGroup):
    """scene.raylab_render: the raylab render engine and the structure comparison (structure, max_depth_auto,
    max_depth, leaf_size, contract, builder from structure_properties)."""

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
    heat_maps_scale: IntProperty(
        name="Heat Maps Scale", default=0, min=0,
        description="The count drawn in the last colour of every heat map, one scale for all (higher "
                    "counts get that colour too); 0: the hardest pixel of all the maps")


# Scene attribute -> its property group.
GROUPS = {"raylab": RAYLAB_PG_scene, "raylab_render": RAYLAB_PG_render}


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(tuple(GROUPS.values()))


def register():
    _register_classes()
    for attribute, cls in GROUPS.items():
        setattr(bpy.types.Scene, attribute, PointerProperty(type=cls))


def unregister():
    for attribute in reversed(GROUPS):
        delattr(bpy.types.Scene, attribute)
    _unregister_classes()
