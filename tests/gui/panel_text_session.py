"""Runs inside a real Blender window (xvfb-run): opens every level and draws every panel of the 3D
viewport's raylab tab into a recording layout, at the sidebar's real width, to measure every text a panel
shows against the room Blender gives it (issue 27: Blender elides the middle of a line that does not fit).

    xvfb-run -a -s "-screen 0 WxHx24" blender --factory-startup START.blend \
        --python tests/gui/panel_text_session.py -- OUT_DIR LEVEL_ID [LEVEL_ID ...]

The recording layout models Blender's layout: a panel's and a box's margins, rows that share their width,
grid columns, a property's label at 40 % of a split row. Each level is also shown with the results its
tools write (the leak test, the heat maps) and with its mesh deleted; OUT_DIR/panel_text.json holds, per
level, the sidebar's width and every text that does not fit (its width and its room), and
OUT_DIR/panel_text_LEVEL.png the window.
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import session  # noqa: E402  (puts the checkout's add-on on sys.path)
from blender_window import click_raylab_tab, screenshot, show_sidebar, view3d  # noqa: E402

OUT_DIR, LEVEL_IDS = session.out_dir(), session.ARGS[1:]
report = {"levels": {}}
SESSION = session.Session(os.path.join(OUT_DIR, "panel_text.json"), report)
SPLIT_LABEL = 0.4  # the share of a split row Blender gives a property's label


class Node:
    """One layout item: a container (column, row, box, grid, split) or a text with its icon."""

    def __init__(self, kind, parent=None, **options):
        self.kind, self.parent, self.options, self.children = kind, parent, options, []
        self.use_property_split = parent.use_property_split if parent is not None else False
        self.text, self.icon = None, 'NONE'

    # containers
    def _child(self, kind, **options):
        node = Node(kind, self, **options)
        self.children.append(node)
        return node

    def column(self, **_):
        return self._child("column")

    def row(self, **_):
        return self._child("row")

    def box(self):
        return self._child("box")

    def split(self, factor=0.0, **_):
        return self._child("split", factor=factor)

    def grid_flow(self, columns=0, **_):
        return self._child("grid", columns=columns)

    def column_flow(self, columns=0, **_):
        return self._child("grid", columns=columns)

    # texts
    def _text(self, kind, text, icon='NONE'):
        node = self._child(kind)
        node.text, node.icon = text, icon
        return node

    def label(self, text="", icon='NONE', icon_value=0, **_):
        self._text("label", text, icon if icon != 'NONE' or not icon_value else 'ICON')

    def operator(self, idname, text=None, icon='NONE', **_):
        if text is None:
            module, _, name = idname.partition(".")
            text = getattr(getattr(bpy.ops, module), name).get_rna_type().name
        self._text("operator", text, icon)
        return _Anything()

    def operator_menu_enum(self, idname, prop, text=None, icon='NONE', **_):
        return self.operator(idname, text, icon)

    def prop(self, data, name, text=None, icon='NONE', expand=False, slider=False, **_):
        rna = data.bl_rna.properties[name]
        label = rna.name if text is None else text
        # A checkbox carries its text beside it, in the value's column when the row is split.
        kind = "prop_bool" if rna.type == 'BOOLEAN' else "prop"
        if expand or not label:
            return
        node = self._text(kind, label, icon)
        node.use_property_split = self.use_property_split

    def separator(self, **_):
        pass

    def template_icon(self, **_):
        pass

    def __getattr__(self, name):  # any other template or setting: nothing to measure
        return _Anything()


class _Anything:
    """What an operator returns (its properties) and any template: takes every attribute and call."""

    def __call__(self, *args, **kwargs):
        return self

    def __getattr__(self, name):
        return self

    def __setattr__(self, name, value):
        pass


def overflowing(root, width, context):
    """[(text, measured, room)] for every text in the tree that is wider than its room."""
    from raylab.blender import text_fit
    s = text_fit.scale(context)
    unit = text_fit.UNIT * s
    pixels = text_fit.font_pixels(context)
    found = []

    def walk(node, room):
        if node.text == "":
            return
        if node.text is not None:
            # A split row gives a property's label 40 % and a checkbox's text the value's 60 %; labels and
            # buttons keep the whole row.
            split = node.use_property_split and node.kind in ("prop", "prop_bool")
            share = room * (SPLIT_LABEL if node.kind == "prop" else 1.0 - SPLIT_LABEL) if split else room
            icon = node.icon != 'NONE' or node.kind == "prop_bool"  # a checkbox takes an icon's room
            free = share - unit * ((text_fit.ICON if icon else 0.0) + text_fit.TEXT_PADDING)
            measured = text_fit.measure(node.text, pixels)
            if measured > free + 0.5:
                found.append((node.text, round(measured, 1), round(free, 1)))
            return
        inner = room - unit * text_fit.BOX_MARGIN if node.kind == "box" else room
        children = node.children
        if node.kind == "row" and children:
            # An icon-only button takes an icon's room; the other items share the rest.
            icons = [c for c in children if c.text == ""]
            rest = ((inner - len(icons) * unit * (text_fit.ICON + text_fit.TEXT_PADDING))
                    / max(1, len(children) - len(icons)))
            for child in children:
                walk(child, rest)
        elif node.kind == "grid" and children:
            columns = node.options["columns"] or 1
            for child in children:
                walk(child, inner / columns)
        elif node.kind == "split" and children:
            factor = node.options["factor"] or 1.0 / len(children)
            for i, child in enumerate(children):
                walk(child, inner * factor if i == 0 else inner * (1 - factor) / max(1, len(children) - 1))
        else:
            for child in children:
                walk(child, inner)

    walk(root, text_fit.panel_width(context, width))
    return found


def sidebar_panels():
    """The panel classes of the 3D viewport's raylab tab, parents first."""
    panels = [cls for cls in bpy.types.Panel.__subclasses__()
              if getattr(cls, "bl_space_type", "") == 'VIEW_3D' and getattr(cls, "bl_region_type", "") == 'UI'
              and getattr(cls, "bl_category", "") == "raylab"]
    return sorted(panels, key=lambda cls: bool(getattr(cls, "bl_parent_id", "")))


def measure_panels(level_id, state):
    window, area, _, sidebar = view3d()
    found = {}
    with bpy.context.temp_override(window=window, area=area, region=sidebar):
        context = bpy.context
        for cls in sidebar_panels():
            if hasattr(cls, "poll") and not cls.poll(context):
                continue
            root = Node("column")

            class Drawing:  # what a panel's draw reads of `self`
                layout = root
                bl_label = cls.bl_label
            cls.draw(Drawing(), context)
            for text, measured, room in overflowing(root, sidebar.width, context):
                found.setdefault(cls.bl_label, []).append([state, text, measured, room])
    entry = report["levels"].setdefault(level_id, {"sidebar_width": sidebar.width, "overflow": {}, "panels": 0})
    for panel, items in found.items():
        entry["overflow"].setdefault(panel, []).extend(items)
    entry["panels"] += 1


def steps_for(level_id):
    from raylab.blender import levels

    def open_level():
        with bpy.context.temp_override(window=view3d().window):
            assert bpy.ops.raylab.level_open(level_id=level_id) == {'FINISHED'}

    def results():  # what the level's own tools write into the panels
        window, area, region, _ = view3d()
        with bpy.context.temp_override(window=window, area=area, region=region):
            if level_id == "where_methods_fail":
                assert bpy.ops.raylab.level_leak_test() == {'FINISHED'}
            if level_id == "where_work_goes":
                assert bpy.ops.raylab.heat_maps(time_limit=0.0) == {"FINISHED"}

    def shot():
        screenshot(os.path.join(OUT_DIR, f"panel_text_{level_id}.png"))

    def without_mesh():
        obj = levels.level_mesh_object(bpy.context.scene)
        bpy.data.objects.remove(obj)

    return [open_level, lambda: None, lambda: measure_panels(level_id, "opened"), shot, results,
            lambda: None, lambda: measure_panels(level_id, "with results"), without_mesh,
            lambda: measure_panels(level_id, "mesh deleted")]


def set_up():
    import raylab
    raylab.register()
    show_sidebar()


steps = [step for level_id in LEVEL_IDS for step in steps_for(level_id)]
steps.insert(1, click_raylab_tab)  # once, with the first level open: the sidebar keeps its tab
# Half a second apart: a step measures what the panels draw, it waits for no picture (but the one shot).
SESSION.run(steps, set_up, interval=0.5)
