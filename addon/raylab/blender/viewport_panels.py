"""The 3D viewport sidebar tab "raylab": Structure, Probe, Cost heat map and Last render panels."""
import bpy

from . import probe, properties, render_stats, structure_cache


def draw_structure_settings(layout, props):
    """The structure and its build settings, each active only where it applies (viewport and render)."""
    layout.prop(props, "structure")
    depth = layout.column()
    depth.active = properties.uses(props.structure, "max_depth")
    depth.prop(props, "max_depth_auto")
    slider = depth.row()
    slider.active = not props.max_depth_auto
    slider.prop(props, "max_depth")
    leaf = layout.row()
    leaf.active = properties.uses(props.structure, "leaf_size")
    leaf.prop(props, "leaf_size")


class _RaylabPanel:
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "raylab"


class RAYLAB_PT_structure(_RaylabPanel, bpy.types.Panel):
    bl_label = "Structure"

    def draw_header(self, context):
        self.layout.prop(context.scene.raylab, "show", text="")

    def draw(self, context):
        settings = context.scene.raylab
        layout = self.layout
        layout.use_property_split = True
        draw_structure_settings(layout, settings)
        layout.prop(settings, "animation_update")
        layout.prop(settings, "objects")
        row = layout.row()
        row.active = not settings.color_by_depth
        row.prop(settings, "line_color")
        column = layout.column(align=True)
        column.prop(settings, "depth_min")
        column.prop(settings, "depth_max")
        # Checkboxes carry their label on the right, at full width: split, the sidebar's default width
        # cut "Colour by depth" to "Colour by…".
        toggles = layout.column(align=True)
        toggles.use_property_split = False
        for name in ("color_by_depth", "leaves_only", "xray", "fade", "spin"):
            toggles.prop(settings, name)
        for obj in structure_cache.target_objects(context.scene, context.view_layer):
            entry = structure_cache.cached(obj, context.scene)
            if entry is not None and entry.error:
                layout.label(text=f"{obj.name}: {entry.error}", icon='ERROR')
            elif entry is not None:
                s = entry.structure
                layout.label(text=f"{obj.name}: {len(entry.boxes()['depth'])} boxes, "
                                  f"{s.memory_bytes / 1024:.0f} KiB, built in {s.build_seconds * 1000:.1f} ms")


class RAYLAB_PT_probe(_RaylabPanel, bpy.types.Panel):
    bl_label = "Ray probe"

    def draw_header(self, context):
        self.layout.prop(context.scene.raylab, "probe_enabled", text="")

    def draw(self, context):
        settings = context.scene.raylab
        layout = self.layout
        layout.use_property_split = True
        layout.prop(settings, "probe_source", expand=True)
        if settings.probe_source == 'OBJECT':
            row = layout.row(align=True)
            row.prop(settings, "probe_object")
            row.operator("raylab.probe_add", text="", icon='ADD')
        else:
            column = layout.column(align=True)
            column.prop(settings, "probe_pixel_x")
            column.prop(settings, "probe_pixel_y")
        layout.prop(settings, "probe_length")
        row = layout.row(align=True)
        row.prop(settings, "fan_enabled")
        sub = row.row()
        sub.active = settings.fan_enabled
        sub.prop(settings, "fan_size", text="N")
        if settings.probe_enabled:
            box = layout.box()
            for line in probe.last_status_text(context.scene):
                for part in line.split(", "):  # the sidebar is narrow: one count per row
                    box.label(text=part)


class RAYLAB_PT_cost(_RaylabPanel, bpy.types.Panel):
    bl_label = "Cost heat map"
    bl_options = {'DEFAULT_CLOSED'}

    def draw_header(self, context):
        self.layout.prop(context.scene.raylab, "cost_enabled", text="")

    def draw(self, context):
        settings = context.scene.raylab
        layout = self.layout
        layout.use_property_split = True
        layout.active = settings.cost_enabled
        layout.prop(settings, "cost_counter")
        layout.prop(settings, "cost_maximum")
        layout.prop(settings, "cost_cells")


class RAYLAB_PT_last_render(_RaylabPanel, bpy.types.Panel):
    bl_label = "Last render"

    def draw(self, context):
        render_stats.draw_last(self.layout, context)


CLASSES = (RAYLAB_PT_structure, RAYLAB_PT_probe, RAYLAB_PT_cost, RAYLAB_PT_last_render)


register, unregister = bpy.utils.register_classes_factory(CLASSES)
