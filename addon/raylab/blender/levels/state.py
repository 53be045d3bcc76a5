"""A level's state on its scene: scene["raylab_level"] (the level's id, the done flags, the mesh object's
name, its start place and mesh, the scene scale, the snapshots of `changed` tests, and the owner stamp:
the scene's name and the token every ID the level made carries); None on other scenes.

Blender copies a scene's ID properties into a scene made from it (New Scene > Copy Settings), so the state
alone does not say a scene is a level: the stamp does. A copy has another name while the level's scene
still holds the stamped one; a renamed level scene is the only scene near its stamp and keeps its state.
"""
STATE_KEY = "raylab_level"
OWNER_KEY = "raylab_level_owner"  # on every ID a level made: the level's token
MESH_OBJECT_NAME = "Level mesh"


def _scenes():
    import bpy  # this module loads without Blender too (the level format's checks)
    return bpy.data.scenes


def stored_state(scene):
    """The state ID property as stored, also on a copy that is not a level."""
    return scene.get(STATE_KEY) if scene is not None else None


def is_copy(scene):
    """True for a scene that carries a level's state copied from the level's scene (still there)."""
    st = stored_state(scene)
    owner = st.get("scene") if st is not None else None
    return owner is not None and owner != scene.name and owner in _scenes()  # a lookup by name, no list of names built


def state(scene):
    """The level state stored on the scene, or None when the scene is not a level."""
    st = stored_state(scene)
    return None if st is None or is_copy(scene) else st


def owned(id_data, token):
    """True if the ID was made by the level whose token (state["token"]) is `token`."""
    return token is not None and id_data is not None and id_data.get(OWNER_KEY) == token


def level_mesh_object(scene):
    st = state(scene)
    return scene.objects.get(st["mesh_object"]) if st else None


def keep_stamps():
    """After Blender changed the scenes: a copy of a level's scene loses the copied state (it is the user's
    scene), and a renamed level scene's stamp follows its new name."""
    import bpy
    for scene in bpy.data.scenes:
        st = stored_state(scene)
        if st is None or st.get("scene") is None:
            continue
        if is_copy(scene):
            del scene[STATE_KEY]
        elif st["scene"] != scene.name:
            st["scene"] = scene.name
