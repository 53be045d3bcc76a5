"""Inside Blender: puts the add-on folder of this checkout on sys.path, so that `import raylab` loads
this package (the same native module the plain-Python tests load)."""
import pathlib
import sys

ADDON = str(pathlib.Path(__file__).resolve().parents[2] / "addon")
if ADDON not in sys.path:
    sys.path.insert(0, ADDON)
