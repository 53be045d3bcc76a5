"""The Blender side of raylab: one module per role, each with register() and unregister().

Add your module to MODULES (order matters: properties before what uses them).
"""
import importlib

MODULES = ["properties", "preferences", "levels", "level_panels", "structure_cache", "overlay", "spin", "probe",
           "cost_overlay", "experiments.leak", "viewport_panels", "tree_view", "cost_passes", "render_engine",
           "compare", "heat_maps"]


def _modules():
    return [importlib.import_module(f".{name}", __name__) for name in MODULES]


def register():
    for module in _modules():
        module.register()


def unregister():
    for module in reversed(_modules()):
        module.unregister()
