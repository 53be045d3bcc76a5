"""The level operators: open a level, the next or the previous one, swap the level's mesh. Each builds
or changes the scene, so each has Undo."""
import bpy

from .meshes import mesh_sources
from .reading import LevelError, available_levels
from .scene import open_level, step_level, swap_mesh


class RAYLAB_OT_level_open(bpy.types.Operator):
    """Build this level's scene from scratch and switch to it"""
    bl_idname = "raylab.level_open"
    bl_label = "Open Level"
    bl_options = {'REGISTER', 'UNDO'}

    level_id: bpy.props.StringProperty(name="Level", description="The level's id (its folder under levels/); "
                                                                 "empty: the first level")

    def invoke(self, context, event):
        """From F3 (no id): a menu of the levels to pick from."""
        if self.level_id:
            return self.execute(context)

        idname = self.bl_idname  # the menu draws after this operator is gone

        def draw(menu, _context):
            for level in available_levels()[0]:
                menu.layout.operator(idname, text=level.title, icon='PLAY').level_id = level.id
        context.window_manager.popup_menu(draw, title="Open Level", icon='PLAY')
        return {'CANCELLED'}

    def execute(self, context):
        try:
            levels = available_levels()[0]
            level_id = self.level_id or (levels[0].id if levels else "")
            open_level(context, level_id)
        except LevelError as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        return {'FINISHED'}


class _LevelStep:
    bl_options = {'REGISTER', 'UNDO'}
    DELTA = 0

    def execute(self, context):
        try:
            step_level(context, self.DELTA)
        except LevelError as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        return {'FINISHED'}


class RAYLAB_OT_level_next(_LevelStep, bpy.types.Operator):
    """Open the next level (from a scene that is not a level: the first one)"""
    bl_idname = "raylab.level_next"
    bl_label = "Next Level"
    DELTA = 1


class RAYLAB_OT_level_previous(_LevelStep, bpy.types.Operator):
    """Open the previous level (from a scene that is not a level: the first one)"""
    bl_idname = "raylab.level_previous"
    bl_label = "Previous Level"
    DELTA = -1


def source_label(source):
    """How a swap source reads in the menu: "bunny.obj" for a shipped mesh, the object's name for the user's."""
    return source.partition(":")[2]


class RAYLAB_MT_level_swap_mesh(bpy.types.Menu):
    """The shipped meshes and the user's objects with a surface, each a Swap Mesh button."""
    bl_label = "Swap Mesh"
    bl_idname = "RAYLAB_MT_level_swap_mesh"

    def draw(self, context):
        column = self.layout.column()
        for source in mesh_sources(context.scene):
            icon = 'FILE_3D' if source.startswith("file:") else 'OBJECT_DATA'
            column.operator(RAYLAB_OT_level_swap_mesh.bl_idname, text=source_label(source), icon=icon).source = source


class RAYLAB_OT_level_swap_mesh(bpy.types.Operator):
    """Swap the level's mesh for a shipped mesh or one of your objects (mesh, curve, surface, text); settings stay"""
    bl_idname = "raylab.level_swap_mesh"
    bl_label = "Swap Mesh"
    bl_options = {'REGISTER', 'UNDO'}

    # A string, not an enum: a script's wrong source gets raylab's sentence, not Blender's enum TypeError.
    source: bpy.props.StringProperty(name="Mesh", description="file:<a shipped .obj> or object:<one of your "
                                                               "objects> (with its modifiers)")

    def invoke(self, context, event):
        if self.source:
            return self.execute(context)
        bpy.ops.wm.call_menu(name=RAYLAB_MT_level_swap_mesh.bl_idname)  # from F3: pick from the menu
        return {'CANCELLED'}

    def execute(self, context):
        try:
            swap_mesh(context.scene, self.source)
        except (LevelError, ValueError) as error:
            self.report({'ERROR'}, f"raylab: {error}")
            return {'CANCELLED'}
        return {'FINISHED'}


CLASSES = (RAYLAB_OT_level_open, RAYLAB_OT_level_next, RAYLAB_OT_level_previous, RAYLAB_OT_level_swap_mesh,
           RAYLAB_MT_level_swap_mesh)


register, unregister = bpy.utils.register_classes_factory(CLASSES)
