"""The native core, _raylab: loads it, or says in one sentence why it cannot.

The module is compiled against one Python's ABI, and it comes in one of two ways: beside this file
(`_raylab.cpython-311-….so`: the development build, the legacy add-on zip), or as the `raylab_core` wheel
(`raylab_core._raylab`: pip, and the 4.2+ extension, which lists one wheel per Python in its manifest and
keeps them in wheels/; Blender installs the one matching its Python). In a Blender whose Python has no
module, the add-on still registers and its preferences say which Python the build needs, instead of a
traceback.
"""
import importlib
import os
import re
import sys

PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))


def built_for():
    """The Python versions ("3.11", ...) whose native module this copy of raylab carries."""
    versions = set()
    wheels = os.path.join(PACKAGE_DIR, "wheels")
    names = os.listdir(PACKAGE_DIR) + (os.listdir(wheels) if os.path.isdir(wheels) else [])
    for name in names:
        match = (re.fullmatch(r"_raylab\.cpython-(\d)(\d+)\S*\.so", name)
                 or re.fullmatch(r"raylab_core-[^-]+-cp(\d)(\d+)-\S+\.whl", name))
        if match:
            versions.add(f"{match[1]}.{match[2]}")
    return sorted(versions, key=lambda v: tuple(map(int, v.split("."))))


def _load():
    """(module, None) or (None, the reason it cannot be loaded, for a person)."""
    running = f"{sys.version_info.major}.{sys.version_info.minor}"
    try:
        try:
            return importlib.import_module("._raylab", __package__), None
        except ModuleNotFoundError:
            return importlib.import_module("raylab_core._raylab"), None
    except ImportError as error:
        versions = built_for()
        if running not in versions:
            built = " and ".join(f"Python {v}" for v in versions) or "no Python (the native module is missing)"
            return None, (f"raylab's native core was built for {built}, but this Blender runs Python "
                          f"{running}. Install the raylab build made for Python {running} "
                          f"(./raylab package on a system whose Python is {running}).")
        return None, f"raylab's native core for Python {running} could not be loaded: {error}"


core, ERROR = _load()
