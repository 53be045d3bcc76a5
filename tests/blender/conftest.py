"""Inside Blender: puts the add-on folder of this checkout on sys.path, so that `import raylab` loads
this package (the same native module the plain-Python tests load), and registers the add-on once."""
import pathlib
import sys

import bpy
import pytest

ADDON = str(pathlib.Path(__file__).resolve().parents[2] / "addon")
if ADDON not in sys.path:
    sys.path.insert(0, ADDON)


@pytest.fixture(scope="session", autouse=True)
def addon_registered():
    import raylab
    if not hasattr(bpy.types.Scene, "raylab"):
        raylab.register()
