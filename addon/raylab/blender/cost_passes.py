"""raylab's cost passes in Blender: which ones a View Layer delivers (view_layer.raylab_passes, drawn in
the View Layer tab), registering them with the render engine the Blender way (update_render_passes), and
writing a render's per-pixel work into them; and the heat pass, one of them in false colour on a fixed,
stated scale (raylab.heat_map) with its legend. The pass list is api.COST_PASS_INFO (declared once in
native/include/raylab/cost_passes.h); nothing here lists a pass or a counter again.

The heat pass starts on the triangle tests with an automatic maximum: a high percentile of the pixels
that did any work, rounded up to a round number, so the first render shows the scene's spread of work (a
fixed 0-100 made a black picture of rays, one or two per pixel). A maximum the user types is kept: the
scale is then fixed, and renders with different structures compare colour for colour."""
import math

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, PointerProperty

from .. import api
from ..heat import HEAT_COLOUR_NAMES
from . import compat, text_fit

# A count per pixel: one float channel, as Blender's Depth pass.
CHANNELS, CHANNEL_ID, PASS_TYPE = 1, "X", 'VALUE'
# The false-colour view of one count: a colour pass.
HEAT_PASS = "raylab Heat"
# The count it shows until the user picks another: where a structure saves or spends.
HEAT_DEFAULT = next(name for name, info in api.COST_PASS_INFO.items() if info["counter"] == "triangle_tests")
# The automatic maximum: this percentile of the pixels that did any work (a few hot pixels do not darken
# the rest), rounded up to the first of these steps times a power of ten.
AUTO_PERCENTILE = 95
ROUND_STEPS = (1, 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10)


def use_property(pass_name):
    """The View Layer checkbox of a pass: use_<counter>, e.g. use_box_tests."""
    return "use_" + api.COST_PASS_INFO[pass_name]["counter"]


def _passes_changed(self, context):
    # The pass menu and the compositor's Render Layers node follow the checkboxes at once. The view
    # layer is the one holding these settings (self.id_data is its scene), not the window's; a ViewLayer
    # has no path from its scene to resolve, so it is found by its settings' address.
    for view_layer in self.id_data.view_layers:
        if view_layer.raylab_passes.as_pointer() == self.as_pointer():
            compat.update_render_passes(view_layer)


def _maximum_set(self, context):
    # A maximum the user sets is the scale from then on.
    self.heat_maximum_auto = False


def _annotations():
    fields = {use_property(name): BoolProperty(
        name=info["label"], default=False, update=_passes_changed,
        description=f"Deliver the \"{name}\" pass: {info['description']}, a float per pixel (exact up to 2^24)")
        for name, info in api.COST_PASS_INFO.items()}
    fields["cost_rays"] = EnumProperty(
        name="Count", default=api.COST_RAYS[0], update=_passes_changed,
        items=[(name, info["label"], info["description"]) for name, info in api.COST_RAYS_INFO.items()],
        description="Which of a pixel's rays the cost passes count")
    fields["use_heat"] = BoolProperty(
        name="Heat", default=False, update=_passes_changed,
        description=f"Deliver the \"{HEAT_PASS}\" pass: one count per pixel in false colour (inferno) on the "
                    "fixed scale 0 to Heat Maximum, with its legend")
    fields["heat_pass"] = EnumProperty(
        name="Heat Of", default=HEAT_DEFAULT,
        items=[(name, info["label"], info["description"]) for name, info in api.COST_PASS_INFO.items()],
        description="The count the heat pass shows")
    fields["heat_maximum_auto"] = BoolProperty(
        name="Auto Maximum", default=True,
        description=f"Each render's top colour is the {AUTO_PERCENTILE}th percentile of its pixels that did "
                    "any work, rounded up (the render states it); off: Heat Maximum, one fixed scale")
    fields["heat_maximum"] = FloatProperty(
        name="Heat Maximum", default=100.0, min=1e-3, soft_max=1e6, update=_maximum_set,
        description="The count shown in the top colour (and anything above it): renders on the same maximum "
                    "compare colour for colour, whatever their structure. Setting it turns Auto Maximum off")
    fields["heat_legend"] = BoolProperty(
        name="Legend in Image", default=True,
        description="Draw the colour bar with its numbers (0, the middle, the maximum) over the heat pass's "
                    "bottom rows, when the image is at least 128 x 96 pixels")
    return fields


RAYLAB_PG_passes = type("RAYLAB_PG_passes", (bpy.types.PropertyGroup,), {
    "__doc__": "view_layer.raylab_passes: the raylab passes this View Layer delivers.",
    "__annotations__": _annotations(),
})


def enabled(props):
    """The names of the passes a View Layer's raylab_passes enable, in COST_PASSES order."""
    return [name for name in api.COST_PASSES if getattr(props, use_property(name))]


def delivered(props):
    """(name, channels, channel ids, type) of every pass a View Layer delivers: Combined, then every enabled
    cost pass, then the heat pass."""
    passes = [("Combined", 4, "RGBA", 'COLOR')]
    passes += [(name, CHANNELS, CHANNEL_ID, PASS_TYPE) for name in enabled(props)]
    if props.use_heat:
        passes.append((HEAT_PASS, 4, "RGBA", 'COLOR'))
    return passes


def register_passes(engine, scene, view_layer):
    """RenderEngine.update_render_passes: what the compositor and the View Layer list offer."""
    for name, channels, ids, kind in delivered(view_layer.raylab_passes):
        engine.register_pass(scene, view_layer, name, channels, ids, kind)


def add_passes(engine, view_layer):
    """The passes put into the render result before it is begun: 3.x and 4.x make a result's passes from
    update_render_passes, 5.x only from add_pass (a pass already there is not added twice)."""
    for name, channels, ids, _ in delivered(view_layer.raylab_passes)[1:]:
        engine.add_pass(name, channels, ids, layer=view_layer.name)


def round_up(value):
    """The first round number (ROUND_STEPS times a power of ten) at or above `value` > 0."""
    power = 10.0 ** math.floor(math.log10(value))
    return next(float(f"{step * power:.6g}") for step in ROUND_STEPS if step * power >= value * (1 - 1e-9))


def automatic_maximum(counts):
    """The heat scale's top for one image of counts: the AUTO_PERCENTILE-th percentile of its pixels that
    did any work, rounded up (round_up); 1 when no pixel did any."""
    working = np.asarray(counts)[np.asarray(counts) > 0]
    return round_up(float(np.percentile(working, AUTO_PERCENTILE))) if working.size else 1.0


def counts_of(cost, props):
    """The counts the heat pass shows, from a render's result.cost."""
    return cost[api.COST_PASS_INFO[props.heat_pass]["counter"]]


def heat_maximum(cost, props):
    """The maximum of one render's heat pass: the automatic one, or the one the user set."""
    return automatic_maximum(counts_of(cost, props)) if props.heat_maximum_auto else props.heat_maximum


def scale_text(props, maximum):
    """The heat scale in words: "Triangle tests per pixel: 0 (black) to 100+ (pale yellow), inferno",
    with how an automatic maximum was found."""
    text = api.heat_scale_text(api.COST_PASS_INFO[props.heat_pass]["label"], maximum)
    return f"{text} (automatic: the {AUTO_PERCENTILE}th percentile)" if props.heat_maximum_auto else text


def heat_scale(props, result):
    """The heat pass's scale in words for one render (the stats line, the Last Render panel), or None
    without a heat pass (result.cost, copied when first read, is left alone then)."""
    return scale_text(props, heat_maximum(result.cost, props)) if props.use_heat else None


def heat_image(cost, props):
    """The heat pass of one render: (H, W, 4) linear RGBA, row 0 the top, the legend over the bottom
    rows when asked and the image is large enough to keep the picture readable above it."""
    maximum = heat_maximum(cost, props)
    image = api.heat_map(counts_of(cost, props), maximum)
    height, width = image.shape[:2]
    if props.heat_legend and width >= 128 and height >= 96:
        legend = api.heat_legend(maximum, width=width)
        image[height - len(legend):] = legend
    return image


def write_passes(render_layer, result, props):
    """Fills the enabled passes of a render result's layer from raylab's result.cost (row 0 the top;
    Blender's buffers start at the bottom row)."""
    for name in enabled(props):
        cost = result.cost[api.COST_PASS_INFO[name]["counter"]]
        _fill(render_layer, name, cost)
    if props.use_heat:  # the colour map is Rec.709: shown in the file's working space (5.0+)
        _fill(render_layer, HEAT_PASS, compat.rec709_to_working(heat_image(result.cost, props)))


def _fill(render_layer, name, pixels):
    render_pass = render_layer.passes.get(name)
    # Blender asked update_render_passes for the result's passes when the render began; one missing is
    # left out rather than failing the render on its job thread.
    if render_pass is not None:
        compat.set_pass_pixels(render_pass, pixels[::-1])


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
        text_fit.label(layout, context, COUNTS_NOTE, icon='INFO')
        layout.separator()
        layout.prop(props, "use_heat")
        heat = layout.column()
        heat.active = props.use_heat
        heat.prop(props, "heat_pass")
        scale = heat.column(align=True)
        scale.use_property_split = False  # labels beside their checkbox, inside their field: none cut short
        scale.prop(props, "heat_maximum_auto")
        maximum = scale.row()
        maximum.active = not props.heat_maximum_auto
        maximum.prop(props, "heat_maximum")
        heat.prop(props, "heat_legend")
        # The scale stated in words: the same maximum in two renders, the same colour, the same count.
        text_fit.label(heat, context, planned_scale_text(props), icon='INFO')


# The count passes hold numbers, not colours: shown as an image, every pixel that did any work is white.
COUNTS_NOTE = ("The passes hold counts (40 tests: 40.0), which the Image Editor shows as white; Heat shows "
               "one of them in colour")


def planned_scale_text(props):
    """The heat scale in words before a render: fixed, or how each render finds its own."""
    if not props.heat_maximum_auto:
        return scale_text(props, props.heat_maximum)
    label = api.COST_PASS_INFO[props.heat_pass]["label"]
    low, high = HEAT_COLOUR_NAMES
    return (f"{label} per pixel: 0 ({low}) to the {AUTO_PERCENTILE}th percentile of each render's pixels "
            f"that did work ({high}); the render states the number")


CLASSES = (RAYLAB_PG_passes, RAYLAB_PT_view_layer_passes)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def register():
    _register_classes()
    bpy.types.ViewLayer.raylab_passes = PointerProperty(type=RAYLAB_PG_passes)


def unregister():
    del bpy.types.ViewLayer.raylab_passes
    _unregister_classes()
