"""A level's state on its scene: scene["raylab_level"] (the level's id, the done flags, the mesh object's
name, its start place and mesh, the scene scale, the snapshots of `changed` tests); None on other scenes."""

STATE_KEY = "raylab_level"
MESH_OBJECT_NAME = "Level mesh"


def state(scene):
    """The level state stored on the scene, or None when the scene is not a level."""
    return scene.get(STATE_KEY) if scene is not None else None


def level_mesh_object(scene):
    st = state(scene)
    return scene.objects.get(st["mesh_object"]) if st else None
