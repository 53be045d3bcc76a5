"""What the add-on registers when its native core cannot load here: the reason, in its preferences."""
import textwrap

import bpy

from . import native


class RAYLAB_AP_native_missing(bpy.types.AddonPreferences):
    bl_idname = __package__

    def draw(self, context):
        box = self.layout.box()
        box.label(text="raylab cannot run in this Blender", icon='ERROR')
        for line in textwrap.wrap(native.ERROR, 70):
            box.label(text=line)


def register():
    print(f"raylab: {native.ERROR}")
    bpy.utils.register_class(RAYLAB_AP_native_missing)


def unregister():
    bpy.utils.unregister_class(RAYLAB_AP_native_missing)
