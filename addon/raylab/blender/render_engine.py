"""The raylab render engine (F12 with Render Engine: raylab) and its Render Properties panels."""
import bpy
import numpy as np

from .. import api
from . import compat

from . import viewport_panels
from .scene_export import build_scene, export_scene, render_settings

# ID properties hold 32-bit ints: larger counts are stored as floats.
_ID_INT_MAX = 2 ** 31 - 1
LAST_RENDER_KEYS = ("structure", "rays_primary", "rays_shadow", "rays_reflection", "rays_refraction",
                    "rays_ignored", "box_tests", "triangle_tests", "nodes_visited", "build_seconds",
                    "render_seconds", "memory_bytes", "width", "height")


def render_exported(exported, props, structure=None, super_sampling=None, progress=None):
    """Build the export with `structure` (default: the scene's) and render it; returns raylab's result.

    Raises ExportError, ValueError (bad geometry or settings) or raylab.BuildError (memory budget)."""
    scene, _ = build_scene(exported, structure=structure or props.structure,
                           max_depth=props.max_depth, leaf_size=props.leaf_size)
    return api.render(scene, exported.camera, exported.lights, exported.materials,
                         render_settings(exported, props, super_sampling), progress=progress)


def id_property_stats(stats, super_sampling):
    """The render statistics as an ID-property dict (scene["raylab_last_render"])."""
    record = {"super_sampling": super_sampling}
    for key in LAST_RENDER_KEYS:
        value = stats[key]
        if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
            value = int(value) if abs(int(value)) <= _ID_INT_MAX else float(value)
        elif not isinstance(value, str):
            value = float(value)
        record[key] = value
    return record


def total_rays(stats):
    return sum(stats[key] for key in ("rays_primary", "rays_shadow", "rays_reflection", "rays_refraction"))


def human_count(n):
    for limit, suffix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if n >= limit:
            return f"{n / limit:.{0 if n >= 100 * limit else 1}f}{suffix}"
    return f"{int(n)}"


def stats_line(stats):
    return (f"raylab {stats['structure']} | build {stats['build_seconds']:.3f} s | "
            f"render {stats['render_seconds']:.2f} s | {human_count(total_rays(stats))} rays | "
            f"{human_count(stats['triangle_tests'])} triangle tests")


class RaylabRenderEngine(bpy.types.RenderEngine):
    bl_idname = "RAYLAB"
    bl_label = "raylab"
    bl_use_preview = False

    def render(self, depsgraph):
        scene = depsgraph.scene
        props = scene.raylab_render
        self.update_stats("", f"raylab {props.structure}: exporting the scene")
        try:
            exported = export_scene(depsgraph)
            self.update_stats("", f"raylab {props.structure}: building and rendering")
            result = render_exported(exported, props, progress=self._progress)
        except (ValueError, api.BuildError) as error:
            self.report({'ERROR'}, f"raylab: {error}")
            self.update_stats("", f"raylab: {error}")
            return
        self._write_image(result.image)
        if result.cancelled:
            self.update_stats("", f"raylab {props.structure}: cancelled")
            return
        scene.original["raylab_last_render"] = id_property_stats(result.stats, props.super_sampling)
        line = stats_line(result.stats)
        # The info text is printed by background renders but cleared from the render window when the
        # render ends; the result's message (error_set) is what the window keeps showing after it.
        self.update_stats("", line)
        self.error_set(line)

    def _progress(self, fraction):
        self.update_progress(fraction)
        return self.test_break()

    def _write_image(self, image):
        height, width = image.shape[:2]
        result = self.begin_result(0, 0, width, height)
        # raylab's row 0 is the top of the picture; Blender's buffers start at the bottom row.
        compat.set_pass_pixels(result.layers[0].passes["Combined"], image[::-1])
        self.end_result(result)


class RaylabRenderPanel:
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "render"
    COMPAT_ENGINES = {'RAYLAB'}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class RAYLAB_PT_render_settings(RaylabRenderPanel, bpy.types.Panel):
    bl_label = "raylab"

    def draw(self, context):
        props = context.scene.raylab_render
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        viewport_panels.draw_structure_settings(layout, props)
        layout.separator()
        layout.prop(props, "super_sampling")
        layout.prop(props, "max_recursion")
        layout.prop(props, "shadows")
        layout.prop(props, "robust_offset")
        layout.prop(props, "shadow_terminator")
        layout.prop(props, "tile_size")
        layout.label(text="World colour: background and ambient", icon='WORLD')


def draw_stats_rows(layout, record):
    """Label rows for one render's statistics (scene["raylab_last_render"] or a comparison row)."""
    rows = (("Structure", record["structure"]),
            ("Size", f"{record['width']} x {record['height']}, SS {record['super_sampling']}"),
            ("Build", f"{record['build_seconds']:.4f} s"),
            ("Render", f"{record['render_seconds']:.3f} s"),
            ("Primary rays", human_count(record["rays_primary"])),
            ("Shadow rays", human_count(record["rays_shadow"])),
            ("Rays ignored", human_count(record["rays_ignored"])),
            ("Box tests", human_count(record["box_tests"])),
            ("Triangle tests", human_count(record["triangle_tests"])),
            ("Memory", f"{record['memory_bytes'] / 1024:.1f} KiB"))
    column = layout.column(align=True)
    for label, value in rows:
        split = column.split(factor=0.5)
        split.label(text=label)
        split.label(text=str(value))


class RAYLAB_PT_render_stats(RaylabRenderPanel, bpy.types.Panel):
    bl_label = "raylab Last Render"

    def draw(self, context):
        record = context.scene.get("raylab_last_render")
        if record is None:
            self.layout.label(text="No raylab render yet (F12)")
            return
        draw_stats_rows(self.layout, record)


# Blender's own panels (format, output, lens, light, ...) that list BLENDER_RENDER, shown for raylab too.
def _compatible_panels():
    return [panel for panel in bpy.types.Panel.__subclasses__()
            if 'BLENDER_RENDER' in getattr(panel, "COMPAT_ENGINES", ())]


_EEVEE_PANELS_USED = ("EEVEE_MATERIAL_PT_surface", "EEVEE_MATERIAL_PT_context_material",
                      "EEVEE_WORLD_PT_surface", "DATA_PT_EEVEE_light")

CLASSES = (RaylabRenderEngine, RAYLAB_PT_render_settings, RAYLAB_PT_render_stats)


def _shared_panels():
    return _compatible_panels() + [getattr(bpy.types, name) for name in _EEVEE_PANELS_USED
                                   if hasattr(bpy.types, name)]


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    for panel in _shared_panels():
        panel.COMPAT_ENGINES.add('RAYLAB')


def unregister():
    for panel in _shared_panels():
        panel.COMPAT_ENGINES.discard('RAYLAB')
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
