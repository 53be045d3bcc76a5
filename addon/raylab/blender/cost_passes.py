"""raylab's cost passes in Blender: which ones a View Layer delivers (view_layer.raylab_passes, drawn in
the View Layer tab), registering them with the render engine the Blender way (update_render_passes), and
writing a render's per-pixel work into them. The pass list is api.COST_PASS_INFO (declared once in
native/include/raylab/cost_passes.h); nothing here lists a pass or a counter again."""
import bpy
from bpy.props import BoolProperty, EnumProperty, PointerProperty

from .. import api
from . import compat

# A count per pixel: one float channel, as Blender's Depth pass.
CHANNELS, CHANNEL_ID, PASS_TYPE = 1, "X", 'VALUE'


def use_property(pass_name):
    """The View Layer checkbox of a pass: use_<counter>, e.g. use_box_tests."""
    return "use_" + api.COST_PASS_INFO[pass_name]["counter"]


def _passes_changed(self, context):
    # The pass menu, the compositor's Render Layers node and the EXR follow the checkboxes at once.
    view_layer = getattr(context, "view_layer", None)
    if view_layer is not None:
        compat.update_render_passes(view_layer)


def _annotations():
    fields = {use_property(name): BoolProperty(
        name=info["label"], default=False, update=_passes_changed,
        description=f"Deliver the \"{name}\" pass: {info['description']}, a float per pixel (exact up to 2^24)")
        for name, info in api.COST_PASS_INFO.items()}
    fields["cost_rays"] = EnumProperty(
        name="Count", default=api.COST_RAYS[0], update=_passes_changed,
        items=[(name, info["label"], info["description"]) for name, info in api.COST_RAYS_INFO.items()],
        description="Which of a pixel's rays the cost passes count")
    return fields


RAYLAB_PG_passes = type("RAYLAB_PG_passes", (bpy.types.PropertyGroup,), {
    "__doc__": "view_layer.raylab_passes: the raylab passes this View Layer delivers.",
    "__annotations__": _annotations(),
})


def enabled(props):
    """The names of the passes a View Layer's raylab_passes enable, in COST_PASSES order."""
    return [name for name in api.COST_PASSES if getattr(props, use_property(name))]


def register_passes(engine, scene, view_layer):
    """RenderEngine.update_render_passes: Combined, then every enabled cost pass."""
    engine.register_pass(scene, view_layer, "Combined", 4, "RGBA", 'COLOR')
    for name in enabled(view_layer.raylab_passes):
        engine.register_pass(scene, view_layer, name, CHANNELS, CHANNEL_ID, PASS_TYPE)


def write_passes(render_layer, result, props):
    """Fills the enabled passes of a render result's layer from raylab's result.cost (row 0 the top;
    Blender's buffers start at the bottom row)."""
    for name in enabled(props):
        cost = result.cost[api.COST_PASS_INFO[name]["counter"]]
        compat.set_pass_pixels(render_layer.passes[name], cost[::-1])


class RAYLAB_PT_view_layer_passes(bpy.types.Panel):
    bl_label = "raylab Passes"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "view_layer"
    COMPAT_ENGINES = {'RAYLAB'}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        props = context.view_layer.raylab_passes
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        column = layout.column(heading="Work per Pixel")
        for name in api.COST_PASSES:
            column.prop(props, use_property(name))
        layout.prop(props, "cost_rays")

CLASSES = (RAYLAB_PG_passes, RAYLAB_PT_view_layer_passes)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.ViewLayer.raylab_passes = PointerProperty(type=RAYLAB_PG_passes)


def unregister():
    del bpy.types.ViewLayer.raylab_passes
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
