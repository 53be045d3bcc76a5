"""The level operators: open a level, step to the next or previous one, swap the level's mesh."""
import bpy

from .meshes import mesh_sources
from .reading import LevelError
from .scene import open_level, step_level, swap_mesh


class RAYLAB_OT_level_open(bpy.types.Operator):
    """Build this level's scene from scratch and switch to it"""
    bl_idname = "raylab.level_open"
    bl_label = "Open Level"
    bl_options = {'REGISTER'}

    level_id: bpy.props.StringProperty(name="Level")

    def execute(self, context):
        try:
            open_level(context, self.level_id)
        except LevelError as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        return {'FINISHED'}


class RAYLAB_OT_level_step(bpy.types.Operator):
    """Open the next or the previous level"""
    bl_idname = "raylab.level_step"
    bl_label = "Next / Previous Level"
    bl_options = {'REGISTER'}

    delta: bpy.props.IntProperty(name="Step", default=1, min=-1, max=1)

    def execute(self, context):
        try:
            step_level(context, self.delta)
        except LevelError as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        return {'FINISHED'}


_source_items = []  # Blender needs Python to keep dynamic enum strings alive


def _mesh_items(_self, context):
    _source_items[:] = [(source, source.partition(":")[2],
                         ("Shipped mesh " if source.startswith("file:") else "Your mesh object ")
                         + source.partition(":")[2]) for source in mesh_sources(context.scene)]
    return _source_items


class RAYLAB_OT_level_swap_mesh(bpy.types.Operator):
    """Swap the level's mesh for a shipped mesh or one of your mesh objects; settings stay"""
    bl_idname = "raylab.level_swap_mesh"
    bl_label = "Swap Mesh"
    bl_options = {'REGISTER', 'UNDO'}
    bl_property = "source"

    source: bpy.props.EnumProperty(name="Mesh", items=_mesh_items)

    def invoke(self, context, event):
        context.window_manager.invoke_search_popup(self)
        return {'RUNNING_MODAL'}

    def execute(self, context):
        try:
            swap_mesh(context.scene, self.source)
        except (LevelError, ValueError) as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        return {'FINISHED'}


CLASSES = (RAYLAB_OT_level_open, RAYLAB_OT_level_step, RAYLAB_OT_level_swap_mesh)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
