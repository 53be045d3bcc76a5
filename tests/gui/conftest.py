"""Every Blender these tests start gets a fresh user folder whose saved preferences turn the splash off:
on a first start (no preferences yet) Blender 4.x covers the window with its Quick Setup screen."""
import os
import shutil
import subprocess
import tempfile

import pytest


@pytest.fixture(scope="session", autouse=True)
def blender_user_folder():
    folder = tempfile.mkdtemp(prefix="raylab_blender_user_")
    saved = {key: os.environ.get(key) for key in ("BLENDER_USER_CONFIG", "BLENDER_USER_SCRIPTS")}
    os.environ["BLENDER_USER_CONFIG"] = os.path.join(folder, "config")
    os.environ["BLENDER_USER_SCRIPTS"] = os.path.join(folder, "scripts")
    subprocess.run(["blender", "-b", "--factory-startup", "--python-expr",
                    "import bpy; bpy.context.preferences.view.show_splash = False; bpy.ops.wm.save_userpref()"],
                   check=True, capture_output=True, timeout=120)
    yield folder
    for key, value in saved.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value
    shutil.rmtree(folder, ignore_errors=True)
