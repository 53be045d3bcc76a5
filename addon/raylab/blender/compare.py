"""Render the active scene once per acceleration structure and compare what each costs and saves."""
import bpy

from .. import api

from . import render_stats
from .render_engine import render_exported
from .scene_export import export_scene


def compare_structures(exported, props, super_sampling=None, structures=api.STRUCTURES):
    """Render one export with every structure: [(structure, raylab render result)], in order."""
    return [(structure, render_exported(exported, props, structure=structure, super_sampling=super_sampling))
            for structure in structures]


class RAYLAB_OT_compare_structures(bpy.types.Operator):
    """Render the scene with every acceleration structure and compare time, tests and memory"""
    bl_idname = "raylab.compare_structures"
    bl_label = "Compare Structures"
    bl_options = {'REGISTER'}

    def execute(self, context):
        scene = context.scene
        props = scene.raylab_render
        try:
            exported = export_scene(context.evaluated_depsgraph_get())
            results = compare_structures(exported, props)
        except (ValueError, api.BuildError) as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        scene["raylab_comparison"] = {structure: render_stats.record(result.stats, props.super_sampling)
                                      for structure, result in results}
        fastest = min(results, key=lambda item: item[1].stats["render_seconds"])[0]
        self.report({'INFO'}, f"raylab: compared {len(results)} structures; fastest render: {fastest}")
        return {'FINISHED'}


class RAYLAB_PT_comparison(bpy.types.Panel):
    bl_label = "Structure Comparison"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "raylab"

    def draw(self, context):
        layout = self.layout
        scene = context.scene
        props = scene.raylab_render
        layout.prop(props, "super_sampling")
        layout.operator(RAYLAB_OT_compare_structures.bl_idname, icon='RENDER_STILL')
        table = scene.get("raylab_comparison")
        if not table:
            return
        first = next(iter(table.values()))
        layout.label(text=render_stats.size_text(first))
        # The sidebar is narrow: one line of four values (a column per structure) under each measure.
        column = layout.column(align=True)
        header = column.grid_flow(row_major=True, columns=len(table), even_columns=True)
        for structure in table.keys():
            header.label(text=structure)
        for key, title, show in render_stats.FIELDS:
            column.separator()
            column.label(text=title)
            values = column.box().grid_flow(row_major=True, columns=len(table), even_columns=True)
            for row in table.values():
                values.label(text=show(row[key]))


CLASSES = (RAYLAB_OT_compare_structures, RAYLAB_PT_comparison)


register, unregister = bpy.utils.register_classes_factory(CLASSES)
