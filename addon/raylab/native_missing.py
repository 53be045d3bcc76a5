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


_register_classes, _unregister_classes = bpy.utils.register_classes_factory((RAYLAB_AP_native_missing,))


def register():
    print(f"raylab: {native.ERROR}")
    _register_classes()


def unregister():
    _unregister_classes()
