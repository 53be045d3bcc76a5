"""The add-on's layout: its modules import each other without a circle, and its build settings (the one
bpy-free module that owns them) build what the core's table of kinds says each kind uses."""
import ast
import types

import pytest

import raylab
from conftest import ADDON
from raylab.blender import build_settings

PACKAGE = ADDON / "raylab"


def module_name(path):
    return ".".join(path.relative_to(ADDON).with_suffix("").parts).removesuffix(".__init__")


def imports_of(source, module, is_package=False):
    """The raylab modules `source` (the text of `module`) imports, at its top or inside a function (an
    import inside a function still makes a circle: it only hides it until the call)."""
    package = module if is_package else module.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
            base = (base + "." + node.module if node.module else base) if node.level else node.module
            names = [base + "." + alias.name for alias in node.names] + [base]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        found.update(name for name in names if name.startswith("raylab"))
    # A module's own packages are imported before it: importing them again closes no circle.
    return {name for name in found if name != module and not module.startswith(name + ".")}


def find_circle(graph):
    """One import circle of {module: modules it imports} as [a, b, ..., a], or None."""
    state, path = {}, []

    def visit(name):
        state[name] = "open"
        path.append(name)
        for target in sorted(graph.get(name, ())):
            if state.get(target) == "open":
                return path[path.index(target):] + [target]
            if target not in state and (circle := visit(target)):
                return circle
        path.pop()
        state[name] = "done"
        return None

    for name in sorted(graph):
        if name not in state and (circle := visit(name)):
            return circle
    return None


def test_the_add_ons_modules_import_each_other_without_a_circle():
    modules = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph = {name: imports_of(path.read_text(encoding="utf-8"), name, path.name == "__init__.py") & modules.keys()
             for name, path in modules.items()}
    assert "raylab.blender.structure_cache" in graph["raylab.blender.probe"]  # the graph is read
    assert find_circle(graph) is None


def test_an_import_inside_a_function_closes_a_circle():
    a = imports_of("from . import b\n", "raylab.blender.a")
    b = imports_of("def f():\n    from .a import x\n", "raylab.blender.b")
    assert find_circle({"raylab.blender.a": a, "raylab.blender.b": b}) == [
        "raylab.blender.a", "raylab.blender.b", "raylab.blender.a"]


VALUES = {"max_depth": 5, "leaf_size": 6, "contract": "fast", "builder": "median"}  # one per setting, none the default
OTHER = {"max_depth": 7, "leaf_size": 8, "contract": "exact", "builder": "lbvh"}  # another value of each


def test_every_setting_has_its_test_values():
    assert set(VALUES) == set(OTHER) == set(build_settings.SETTINGS)


def props(structure, max_depth_auto=False, **changed):
    """A property group as build_settings reads it: every setting of SETTINGS, each with its own value."""
    return types.SimpleNamespace(structure=structure, max_depth_auto=max_depth_auto, **{**VALUES, **changed})


@pytest.mark.parametrize("structure", raylab.STRUCTURES)
def test_the_cache_key_holds_only_the_settings_a_kind_uses(structure):
    info = raylab.STRUCTURE_INFO[structure]
    key = build_settings.cache_key(props(structure))
    assert key == (structure, *(VALUES[s] if info[f"uses_{s}"] else None for s in build_settings.SETTINGS))
    for setting in build_settings.SETTINGS:  # a setting the kind does not use changes no key: no rebuild
        other = build_settings.cache_key(props(structure, **{setting: OTHER[setting]}))
        assert (other == key) != info[f"uses_{setting}"], setting


def test_auto_depth_is_the_cores_auto_and_every_build_takes_the_same_arguments():
    assert build_settings.max_depth(props("octree", max_depth_auto=True)) == "auto"
    kwargs = build_settings.build_kwargs(props("octree"), "bvh")
    assert kwargs == dict(structure="bvh", **VALUES)
    vertices, triangles = raylab.load_mesh(PACKAGE / "meshes" / "sphere.obj")
    octree = raylab.build(vertices, triangles, **build_settings.build_kwargs(props("octree")))
    assert octree.max_depth == VALUES["max_depth"]
    assert octree.contract == "exact"  # a kind without a fast contract builds exact, not refused
    assert octree.builder == raylab.DEFAULTS["builder"]  # nor a builder: the default, not refused
    bvh = raylab.build(vertices, triangles, **build_settings.build_kwargs(props("bvh")))
    assert bvh.contract == "fast" and bvh.leaf_size == VALUES["leaf_size"] and bvh.builder == VALUES["builder"]
    scene = raylab.Scene(**build_settings.build_kwargs(props("octree", max_depth_auto=True)))
    assert scene is not None
