"""The Levels panel in the 3D viewport's sidebar tab "raylab": the list of levels, the open level's
title, goal, text with its diagrams, self-ticking tasks and the mesh swap with the mesh's credit."""

import bpy

from . import diagrams, levels, text_fit

TASK_SECTIONS = []  # draw(layout, context) hooks drawn under the tasks, before the controls


def current_level(context):
    st = levels.state(context.scene)
    if st is None:
        return None
    try:
        return levels.find_level(st["id"], from_memory=True)  # a draw asks: see available_levels
    except levels.LevelError:
        return None


class _LevelPanel:
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "raylab"


def _level_buttons(layout, context, current):
    try:
        all_levels, errors = levels.available_levels(from_memory=True)
    except levels.LevelError as error:
        text_fit.label(layout, context, str(error), 'ERROR')
        return
    column = layout.column(align=True)
    # A button cannot wrap: when a title is too long for its button, every button shows the level's name
    # alone, the part of its title before the colon.
    whole = all(text_fit.fits(context, item.title, icon=True) for item in all_levels)
    for item in all_levels:
        is_current = current is not None and item.id == current.id
        title = item.title if whole else item.title.partition(":")[0]
        op = column.operator(levels.RAYLAB_OT_level_open.bl_idname, text=title, depress=is_current,
                             icon='CHECKMARK' if is_current else 'PLAY')
        op.level_id = item.id
    for error in errors:
        text_fit.label(layout, context, str(error), 'ERROR')


class RAYLAB_PT_levels(_LevelPanel, bpy.types.Panel):
    """The open level's title, goal and next / previous; without one, the list of levels."""
    bl_label = "Levels"

    def draw(self, context):
        layout = self.layout
        level = current_level(context)
        if level is None:
            layout.label(text="Open a level to start:")
            _level_buttons(layout, context, None)
        row = layout.row(align=True)
        row.operator(levels.RAYLAB_OT_level_previous.bl_idname, text="Previous", icon='TRIA_LEFT')
        row.operator(levels.RAYLAB_OT_level_next.bl_idname, text="Next", icon='TRIA_RIGHT')
        if level is not None:
            box = layout.box()
            text_fit.label(box, context, level.title, 'INFO', boxes=1)
            text_fit.label(box, context, "Goal: " + level.goal, boxes=1)


# The sub-panels of Levels by bl_order: the tasks right under the goal, where a student sees them tick while
# working, a panel a level works with right under them (tree_view.RAYLAB_PT_level_tree), the tutorial's text
# below.
TASKS_ORDER = 1


class OpenLevelPanel(_LevelPanel):
    bl_parent_id = "RAYLAB_PT_levels"

    @classmethod
    def poll(cls, context):
        return current_level(context) is not None


class RAYLAB_PT_level_text(OpenLevelPanel, bpy.types.Panel):
    bl_label = "Tutorial"
    bl_order = TASKS_ORDER + 2

    def draw(self, context):
        layout = self.layout
        for block in current_level(context).blocks:
            kind = block[0]
            if kind == "heading":
                layout.separator()
                text_fit.label(layout, context, block[1], 'BOOKMARKS')
            elif kind == "paragraph":
                text_fit.label(layout, context, block[1])
            elif kind == "bullet":
                text_fit.label(layout, context, block[1], 'DOT')
            else:
                diagrams.draw(layout, context, *block[1:])


class RAYLAB_PT_level_tasks(OpenLevelPanel, bpy.types.Panel):
    bl_label = "Tasks"
    bl_order = TASKS_ORDER

    def draw(self, context):
        layout = self.layout
        tasks = levels.task_list(context.scene)
        first_open = next((i for i, (_, done) in enumerate(tasks) if not done), None)
        for i, (text, done) in enumerate(tasks):
            column = layout.column()
            column.active = done or i == first_open  # later tasks wait their turn
            text_fit.label(column, context, text, 'CHECKBOX_HLT' if done else 'CHECKBOX_DEHLT')
        for draw_section in TASK_SECTIONS:  # the experiments' results (experiments/*.py add theirs)
            draw_section(layout, context)
        if tasks and first_open is None:
            text_fit.label(layout, context, "All done: on to the next level!", 'FUND')
        controls = current_level(context).controls
        if controls:
            layout.separator()
            column = layout.column()
            for control in controls:
                if control.startswith("operator:"):
                    column.operator(control.partition(":")[2])
                    continue
                group, _, prop = control.partition(".")
                data = getattr(context.scene, group)
                if data.bl_rna.properties[prop].type == 'BOOLEAN':
                    column.prop(data, prop)  # a checkbox, its name beside it
                else:  # the name on its own line: a split row's 40 % cut "Heat Maps Scale" on 4.x
                    text_fit.label(column, context, data.bl_rna.properties[prop].name + ":", scale_y=0.7)
                    column.prop(data, prop, text="")


class RAYLAB_PT_level_mesh(OpenLevelPanel, bpy.types.Panel):
    bl_label = "Level mesh"
    bl_order = TASKS_ORDER + 3

    def draw(self, context):
        layout = self.layout
        obj = levels.level_mesh_object(context.scene)
        if obj is None:
            text_fit.label(layout, context, "The level's mesh was deleted: open the level again", 'ERROR')
            return
        text_fit.label(layout, context, f"{obj.get('raylab_mesh_source', '?')}: {len(obj.data.polygons):,} triangles",
                       'MESH_DATA')
        text_fit.label(layout, context, "Credit: " + obj.get("raylab_credit", ""))
        layout.menu(levels.RAYLAB_MT_level_swap_mesh.bl_idname, text="Swap mesh", icon='FILE_REFRESH')


class RAYLAB_PT_level_list(OpenLevelPanel, bpy.types.Panel):
    bl_label = "All levels"
    bl_options = {'DEFAULT_CLOSED'}
    bl_order = TASKS_ORDER + 4

    def draw(self, context):
        _level_buttons(self.layout, context, current_level(context))


CLASSES = (diagrams.RAYLAB_OT_level_show_diagram, RAYLAB_PT_levels, RAYLAB_PT_level_tasks, RAYLAB_PT_level_text,
           RAYLAB_PT_level_mesh, RAYLAB_PT_level_list)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def register():
    _register_classes()


def unregister():
    _unregister_classes()
    diagrams.release()
