"""Puts the add-on folder on sys.path so that `import raylab` loads the package of this checkout (or the
one in $RAYLAB_ADDON_DIR: ./raylab test --sanitize points it at the sanitized build's copy)."""
import functools
import os
import pathlib
import sys

import pytest

ADDON = pathlib.Path(os.environ.get("RAYLAB_ADDON_DIR", pathlib.Path(__file__).resolve().parents[2] / "addon"))
sys.path.insert(0, str(ADDON))

import raylab  # noqa: E402

MESH_DIR = ADDON / "raylab" / "meshes"
MESHES = sorted(p.stem for p in MESH_DIR.glob("*.obj"))
# The closed meshes, as listed in meshes/CREDITS.md: rays from inside must never escape.
CLOSED_MESHES = ("sphere", "spot_low_resolution", "goathead", "bunny", "armadillo", "bunny_hr", "koala", "dragon")


@functools.lru_cache(maxsize=None)
def load(name):
    """The mesh `name` from the add-on's meshes folder, loaded once per session (read-only arrays)."""
    vertices, triangles = raylab.load_mesh(MESH_DIR / f"{name}.obj")
    vertices.flags.writeable = False
    triangles.flags.writeable = False
    return vertices, triangles


@pytest.fixture(scope="session")
def sphere():
    return load("sphere")
