"""The add-on's Preferences (Edit > Preferences > Add-ons > raylab): the comparison's time limit, whether
the structure overlay starts on in the files a user opens, and a link to the documentation (the README,
shipped in the add-on's zip and at the top of a checkout).

settings() reads them anywhere, also when the add-on was registered by a script rather than enabled in
the Preferences (the tests, `import raylab; raylab.register()`): then the defaults below apply."""
import os
from types import SimpleNamespace

import bpy
from bpy.app.handlers import persistent
from bpy.props import BoolProperty, FloatProperty

# "raylab" as a legacy add-on, "bl_ext.<repository>.raylab" as an extension.
ADDON = __package__.rpartition(".")[0]
_PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
README_PATHS = (os.path.join(_PACKAGE_DIR, "README.md"), os.path.join(_PACKAGE_DIR, os.pardir, os.pardir, "README.md"))

DEFAULTS = dict(
    # Brute force on the race level's dragon takes minutes: past this estimate a structure is skipped.
    compare_time_limit=30.0,
    # A user's own file is theirs: the overlay waits until they turn it on (levels turn it on themselves).
    overlay_in_user_files=False,
)


class RAYLAB_AP_preferences(bpy.types.AddonPreferences):
    bl_idname = ADDON

    compare_time_limit: FloatProperty(
        name="Compare Time Limit", default=DEFAULTS["compare_time_limit"], min=0.0, soft_max=600.0,
        unit='TIME_ABSOLUTE',
        description="Compare Structures skips a structure whose render it estimates to take longer "
                    "than this, in seconds (0: no limit)")
    overlay_in_user_files: BoolProperty(
        name="Overlay On in Your Files", default=DEFAULTS["overlay_in_user_files"],
        description="Draw the structure overlay in the files you open, not only in the levels")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "compare_time_limit")
        layout.prop(self, "overlay_in_user_files")
        readme = documentation()
        if readme is not None:
            layout.operator("wm.path_open", text="Documentation (README)", icon='HELP').filepath = readme


def documentation():
    """The README's path, or None when it is not beside the add-on."""
    return next((os.path.normpath(p) for p in README_PATHS if os.path.isfile(p)), None)


def settings(context=None):
    """The preferences, or the defaults when the add-on is not enabled through the Preferences."""
    addon = (context or bpy.context).preferences.addons.get(ADDON)
    return addon.preferences if addon is not None else SimpleNamespace(**DEFAULTS)


@persistent
def _overlay_default(_file):
    """A file's scenes that never had the overlay switched either way get the preferred default."""
    show = settings().overlay_in_user_files
    for scene in bpy.data.scenes:
        if not scene.raylab.is_property_set("show"):
            scene.raylab.show = show


_register_classes, _unregister_classes = bpy.utils.register_classes_factory((RAYLAB_AP_preferences,))


def register():
    _register_classes()
    bpy.app.handlers.load_post.append(_overlay_default)


def unregister():
    if _overlay_default in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_overlay_default)
    _unregister_classes()
