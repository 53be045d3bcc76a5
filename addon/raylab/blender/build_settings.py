"""A structure's build settings as the add-on's two property groups hold them (scene.raylab for the
viewport, scene.raylab_render for F12 and the comparison): which settings a kind uses, the depth rule,
the cache key, and the keyword arguments of every build (raylab.Scene, raylab.build, build_scene).

No bpy here: `props` is anything with structure, max_depth_auto, max_depth, leaf_size, contract and
builder (a property group, or a SimpleNamespace in a test). properties.py defines those six for both
groups in one place.
"""
from .. import api

SETTINGS = ("max_depth", "leaf_size", "contract", "builder")  # a kind uses one when api.STRUCTURE_INFO[kind]["uses_<setting>"]


def uses(structure, setting):
    """Whether `setting` (one of SETTINGS) changes the build of `structure`."""
    return api.STRUCTURE_INFO[structure][f"uses_{setting}"]


def max_depth(props):
    """"auto" (the core derives the depth from the triangle count and the memory budget) or the slider's
    depth: the Auto depth checkbox and the depth slider are one setting of the core."""
    return "auto" if props.max_depth_auto else props.max_depth


def contract(props, structure):
    """The group's contract where `structure` takes one, else the exact default: the core refuses the fast
    contract for a kind without it, and the comparison builds every kind with one group's settings."""
    return props.contract if uses(structure, "contract") else api.DEFAULTS["contract"]


def builder(props, structure):
    """The group's BVH builder where `structure` takes one, else the default (refused otherwise, as the
    contract)."""
    return props.builder if uses(structure, "builder") else api.DEFAULTS["builder"]


def build_kwargs(props, structure=None):
    """structure, max_depth, leaf_size, contract and builder of a build from `props`; `structure` builds
    another kind with the group's settings (the comparison builds every kind)."""
    structure = structure or props.structure
    return dict(structure=structure, max_depth=max_depth(props), leaf_size=props.leaf_size,
                contract=contract(props, structure), builder=builder(props, structure))


def cache_key(props):
    """The build settings that matter for props.structure: a change to a setting it does not use costs no
    rebuild."""
    kwargs = build_kwargs(props)
    structure = kwargs["structure"]
    return (structure,) + tuple(kwargs[s] if uses(structure, s) else None for s in SETTINGS)
