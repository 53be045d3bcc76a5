"""The 3D viewport sidebar tab "raylab": Structure, Probe, Cost heat map and Last render panels.

The Structure, Probe and Cost panels draw their text with text_fit.label, wrapped to the sidebar's width
(Blender would elide it; the Last render panel's text is render_stats'). The Structure panel keys the
colours by depth (overlay.DEPTH_PALETTE, drawn as icons) and ranks the shown objects by their share of
the triangle tests of the camera's rays (cost_overlay.object_costs): the costliest TOP_OBJECTS, then how
many more.
"""
import bpy

from .. import api
from . import build_settings, cost_overlay, level_panels, overlay, probe, render_stats, structure_cache, text_fit

TOP_OBJECTS = 5      # objects listed by name in the ranking
KEY_SWATCH = 16      # pixels of a depth colour's icon
KEY_ITEM_UNITS = 2.6  # the width of one "swatch and depth" of the key, in UI units


def draw_structure_settings(layout, props):
    """The structure and its build settings, each active only where it applies (viewport and render)."""
    layout.prop(props, "structure")
    depth = layout.column()
    depth.active = build_settings.uses(props.structure, "max_depth")
    depth.prop(props, "max_depth_auto")
    slider = depth.row()
    slider.active = not props.max_depth_auto
    slider.prop(props, "max_depth")
    leaf = layout.row()
    leaf.active = build_settings.uses(props.structure, "leaf_size")
    leaf.prop(props, "leaf_size")
    contract = layout.row()
    contract.active = build_settings.uses(props.structure, "contract")
    contract.prop(props, "contract")
    builder = layout.row()
    builder.active = build_settings.uses(props.structure, "builder")
    builder.prop(props, "builder")


def labelled(layout, props, name, factor=0.5):
    """A property with its label, the label taking `factor` of the width: Blender's split (40 % for the
    label) cut "On animation" and "Line colour" to "On ani…" and "Line col…" at the sidebar's default
    width. Returns the row holding the value."""
    split = layout.split(factor=factor, align=True)
    split.use_property_split = False  # this split is the property's own
    label = split.row()
    label.alignment = 'RIGHT'
    label.label(text=props.bl_rna.properties[name].name)
    value = split.row(align=True)
    value.prop(props, name, text="")
    return value


class SidebarPanel:
    """The raylab tab of the 3D viewport's sidebar (N)."""
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "raylab"


class RAYLAB_PT_structure(SidebarPanel, bpy.types.Panel):
    bl_label = "Structure"

    def draw_header(self, context):
        self.layout.prop(context.scene.raylab, "show", text="")

    def draw(self, context):
        settings = context.scene.raylab
        layout = self.layout
        layout.use_property_split = True
        draw_structure_settings(layout, settings)
        labelled(layout, settings, "animation_update")
        labelled(layout, settings, "objects")
        labelled(layout, settings, "line_color").active = not settings.color_by_depth
        column = layout.column(align=True)
        column.use_property_split = False  # the label inside the field: "Depth from 0"
        column.prop(settings, "depth_min")
        column.prop(settings, "depth_max")
        # Checkboxes carry their label on the right, at full width: split, the sidebar's default width
        # cut "Colour by depth" to "Colour by…".
        toggles = layout.column(align=True)
        toggles.use_property_split = False
        for name in ("color_by_depth", "leaves_only", "xray", "fade", "spin"):
            toggles.prop(settings, name)
        if settings.color_by_depth:
            draw_depth_key(layout, context)
        if settings.show or settings.cost_enabled:  # the viewport's draw keeps the ranking up to date then
            draw_objects(layout, context)


def draw_depth_key(layout, context):
    """The colours by depth as a key: each depth drawn, its colour and its number, as many a row as fit."""
    settings = context.scene.raylab
    key = overlay.depth_key(settings, overlay.drawn_depths(context.scene, context.view_layer))
    box = text_box(layout)
    if not key:
        text_fit.label(box, context, "Depth colours: no box drawn yet", boxes=1)
        return
    text_fit.label(box, context, "Depth colours (the boxes at each depth):", boxes=1)
    room = text_fit.available(context, boxes=1) + text_fit.UNIT * text_fit.scale(context) * text_fit.TEXT_PADDING
    per_row = max(1, int(room // (KEY_ITEM_UNITS * text_fit.UNIT * text_fit.scale(context))))
    grid = box.grid_flow(row_major=True, columns=per_row, even_columns=True, align=True)
    for depth, colour in key:
        grid.label(text=str(depth), icon_value=depth_icon(colour))


_icons = []  # the bpy.utils.previews collection of the key's swatches, made when first drawn


def depth_icon(colour):
    """The icon id of a swatch of one RGBA colour (made once per colour)."""
    if not _icons:
        import bpy.utils.previews
        _icons.append(bpy.utils.previews.new())
    icons = _icons[0]
    name = "depth " + " ".join(f"{c:.4f}" for c in colour)
    if name not in icons:
        swatch = icons.new(name)
        pixels = [*colour[:3], 1.0] * (KEY_SWATCH * KEY_SWATCH)
        swatch.icon_size = swatch.image_size = (KEY_SWATCH, KEY_SWATCH)
        swatch.icon_pixels_float = swatch.image_pixels_float = pixels
    return icons[name].icon_id


def object_lines(context):
    """The Structure panel's lines about the shown objects, as (text, icon): why any is not traced, then
    the objects ranked by their share of the triangle tests, the costliest TOP_OBJECTS by name and how
    many more."""
    scene = context.scene
    entries = structure_cache.cached_entries(scene)  # every shown geometry: text and instances too
    lines = [(f"{name}: {entry.error}", 'ERROR') for name, entry in entries.items() if entry and entry.error]
    built = {name: entry for name, entry in entries.items() if entry and entry.structure is not None}
    if not built:
        return lines
    costs, why_not = cost_overlay.last_object_costs(scene)
    if costs is None:
        return lines + [(f"Costliest objects: {why_not}", 'INFO')]
    ranked = [(name, share) for name, _, share in costs.ranked() if name in built]
    sample = "" if costs.told == costs.rays else f" (shares from a sample of {costs.told:,} of them)"
    counted = api.COUNTER_INFO[cost_overlay.RANK_COUNTER]["label"].lower()
    lines.append((f"Costliest objects, by their share of the {counted} of {costs.rays:,} rays from the "
                  f"camera{sample}:", 'SORTSIZE'))
    lines += [(f"{share_text(share)} {name}: {structure_text(built[name])}", 'NONE')
              for name, share in ranked[:TOP_OBJECTS]]
    rest = ranked[TOP_OBJECTS:]
    if rest:
        lines.append((f"and {len(rest)} more, {share_text(sum(share for _, share in rest))} together", 'NONE'))
    return lines


def share_text(share):
    return "<1%" if 0 < share < 0.005 else f"{share:.0%}"


def structure_text(entry):
    s = entry.structure
    return (f"{entry.box_count:,} {'box' if entry.box_count == 1 else 'boxes'}, {s.memory_bytes / 1024:.0f} KiB, "
            f"built in {s.build_seconds * 1000:.1f} ms")


def draw_objects(layout, context):
    column = layout.column()
    column.use_property_split = False  # texts at the panel's full width (a label is never split)
    for i, (text, icon) in enumerate(object_lines(context)):
        if i:
            column.separator(factor=0.5)  # where one object's wrapped lines end
        text_fit.label(column, context, text, icon=icon)


def text_box(layout):
    """A box of texts at its full width, in a panel whose properties are split."""
    box = layout.box()
    box.use_property_split = False
    return box


class RAYLAB_PT_probe(SidebarPanel, bpy.types.Panel):
    bl_label = "Ray probe"

    def draw_header(self, context):
        self.layout.prop(context.scene.raylab, "probe_enabled", text="")

    def draw(self, context):
        settings = context.scene.raylab
        layout = self.layout
        layout.use_property_split = True
        source = layout.row()
        source.use_property_split = False  # "Object" and "Camera" at full width (split: "Cam…")
        source.prop(settings, "probe_source", expand=True)
        if settings.probe_source == 'OBJECT':  # the field at full width, under its label (split: "ra")
            column = layout.column(align=True)
            column.label(text=settings.bl_rna.properties["probe_object"].name)
            row = column.row(align=True)
            row.prop(settings, "probe_object", text="")
            row.operator("raylab.probe_add", text="", icon='ADD')
        else:
            column = layout.column(align=True)
            column.prop(settings, "probe_pixel_x")
            column.prop(settings, "probe_pixel_y")
        length = layout.column()
        length.use_property_split = False  # the label inside the field: "Ray length 20 m"
        length.prop(settings, "probe_length")
        row = layout.row(align=True)
        row.use_property_split = False  # "Fan" beside its checkbox, N beside it: no split column
        row.prop(settings, "fan_enabled")
        sub = row.row()
        sub.active = settings.fan_enabled
        sub.prop(settings, "fan_size", text="N")
        if settings.probe_enabled:
            box = text_box(layout)
            for line in probe.last_status_text(context.scene):
                for part in line.split(", "):  # one count per row, each wrapped to the sidebar
                    text_fit.label(box, context, part, boxes=1)


class RAYLAB_PT_cost(SidebarPanel, bpy.types.Panel):
    bl_label = "Cost heat map"
    bl_options = {'DEFAULT_CLOSED'}

    def draw_header(self, context):
        self.layout.prop(context.scene.raylab, "cost_enabled", text="")

    def draw(self, context):
        settings = context.scene.raylab
        layout = self.layout
        layout.active = settings.cost_enabled
        labelled(layout, settings, "cost_counter", factor=0.35)  # "Triangle tests" needs the room
        column = layout.column(align=True)  # the labels inside the fields: "Scale maximum 64"
        column.prop(settings, "cost_maximum")
        column.prop(settings, "cost_cells")


class RAYLAB_PT_last_render(SidebarPanel, bpy.types.Panel):
    bl_label = "Last render"

    def draw(self, context):
        render_stats.draw_last(self.layout, context)


def reads_last_render(level):
    """Whether a level's tasks ask for a render's numbers (a task done when the last render exists)."""
    return level is not None and any(task.condition.get("id_property") == render_stats.LAST_RENDER
                                     for task in level.tasks)


def last_render_in_tasks(layout, context):
    """A level_panels.TASK_SECTIONS hook: where a task says "render and read Rays ignored", the last render's
    numbers under the tasks (the Last render panel sits at the sidebar's bottom, the render window's header
    is cut at a level's small resolution)."""
    if reads_last_render(level_panels.current_level(context)) and render_stats.LAST_RENDER in context.scene:
        box = layout.box()
        text_fit.label(box, context, "Last render (F12):", 'RENDER_RESULT', boxes=1)
        render_stats.draw(box, context, context.scene[render_stats.LAST_RENDER])


CLASSES = (RAYLAB_PT_structure, RAYLAB_PT_probe, RAYLAB_PT_cost, RAYLAB_PT_last_render)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def register():
    _register_classes()
    level_panels.TASK_SECTIONS.append(last_render_in_tasks)


def unregister():
    if last_render_in_tasks in level_panels.TASK_SECTIONS:
        level_panels.TASK_SECTIONS.remove(last_render_in_tasks)
    _unregister_classes()
    if _icons:
        import bpy.utils.previews
        bpy.utils.previews.remove(_icons.pop())
