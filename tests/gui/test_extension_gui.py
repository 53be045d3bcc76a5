"""Installing raylab like a user: ./raylab package's zip goes into a fresh Blender user folder (the
extension on Blender 4.2+, the legacy add-on zip on 3.x), then a real Blender window (under Xvfb) enables
it, opens every level and renders F12. Writes out/gui/extension_octree_2.png and extension_render_f12.png."""
import json
import os
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest
from matplotlib import image as mpimg

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HERE = os.path.join(ROOT, "tests", "gui")
OUT = os.path.join(ROOT, "out", "gui")
sys.path.insert(0, os.path.join(ROOT, "tools"))
import package  # noqa: E402


def blender_version():
    line = subprocess.run(["blender", "--version"], capture_output=True, text=True, check=True).stdout.split("\n")[0]
    return tuple(int(part) for part in line.split()[1].split(".")[:2])


@pytest.fixture(scope="module")
def packaged(tmp_path_factory):
    out = tmp_path_factory.mktemp("package")
    run = subprocess.run([sys.executable, os.path.join(ROOT, "tools", "package.py"), "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    version = package.addon_version()
    return {"extension": out / f"raylab-{version}-linux-x64.zip", "legacy": out / f"raylab-{version}-addon-linux-x64.zip"}


def test_extension_zip_has_a_valid_manifest_and_a_self_contained_module(packaged):
    import tomllib
    with zipfile.ZipFile(packaged["extension"]) as zf:
        names = zf.namelist()
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode())
    assert manifest["schema_version"] == "1.0.0" and manifest["id"] == "raylab" and manifest["type"] == "add-on"
    assert manifest["blender_version_min"] == "4.2.0" and manifest["platforms"] == ["linux-x64"]
    assert manifest["license"] and manifest["permissions"]["files"]
    tag = package.python_tag()
    assert f"_raylab.cpython-{tag[2:]}-x86_64-linux-gnu.so" in names
    assert any(name.startswith(f"libs/{tag}/libtbb-") for name in names), names
    # OpenImageIO stays out of what Blender loads; the development modules are not shipped.
    assert not any("_raylab_images" in name or "OpenImageIO" in name for name in names)
    assert "__init__.py" in names and "levels/octree_2/level.toml" in names
    with zipfile.ZipFile(packaged["legacy"]) as zf:
        assert "raylab/__init__.py" in zf.namelist() and "raylab/blender_manifest.toml" not in zf.namelist()


@pytest.fixture(scope="module")
def session(packaged, tmp_path_factory):
    user = tmp_path_factory.mktemp("blender_user")
    env = dict(os.environ, BLENDER_USER_CONFIG=str(user / "config"), BLENDER_USER_SCRIPTS=str(user / "scripts"),
               BLENDER_USER_EXTENSIONS=str(user / "extensions"), BLENDER_USER_DATAFILES=str(user / "datafiles"))
    if blender_version() >= (4, 2):
        module = "bl_ext.user_default.raylab"
        install = ["blender", "-b", "--command", "extension", "install-file", "-r", "user_default",
                   str(packaged["extension"])]
    else:
        module = "raylab"
        install = ["blender", "-b", "--python-exit-code", "1", "--python-expr",
                   f"import bpy; bpy.ops.preferences.addon_install(filepath={str(packaged['legacy'])!r})"]
    run = subprocess.run(install, env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    os.makedirs(OUT, exist_ok=True)
    shots = tmp_path_factory.mktemp("shots")
    # A file opened from the command line keeps the first-run splash screen out of the screenshots.
    blend = shots / "empty.blend"
    subprocess.run(["blender", "-b", "--factory-startup", "--python-expr",
                    f"import bpy; bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})"],
                   env=env, check=True, capture_output=True, timeout=120)
    report_path = shots / "report.json"
    run = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1600x900x24", "blender", str(blend), "--python-exit-code", "1",
                          "--python", os.path.join(HERE, "extension_session.py"), "--", module, str(report_path),
                          str(shots)], env=env, capture_output=True, text=True, timeout=600)
    assert report_path.exists(), run.stdout[-3000:] + run.stderr[-3000:]
    report = json.loads(report_path.read_text())
    for name in ("octree_2", "render_f12"):
        if (shots / f"{name}.png").exists():
            shutil.copy(shots / f"{name}.png", os.path.join(OUT, f"extension_{name}.png"))
    report["user"], report["shots"] = str(user), shots
    return report


def test_installed_addon_is_loaded_from_the_user_folder_not_the_checkout(session):
    assert not session["errors"], session["errors"]
    assert session["enabled"] and session["native_error"] is None
    assert session["module_file"].startswith(session["user"]), session["module_file"]


def test_every_level_opens_from_the_installed_addon(session):
    assert not session["broken_levels"] and not session["level_errors"], session
    assert len(session["level_ids"]) >= 9 and session["levels_opened"] == session["level_ids"]
    assert session["levels_root"].startswith(session["user"])
    assert session["probe_status"]


def test_f12_renders_through_the_installed_extension(session):
    assert session["last_render"]["structure"] == session["render_structure"]
    assert session["last_render"]["rays_primary"] > 0 and session["last_render"]["triangle_tests"] > 0
    pixels = (mpimg.imread(session["shots"] / "render_f12.png")[:, :, :3] * 255).astype(np.int32)
    region = session["image_region"]
    top = pixels.shape[0] - (region["y"] + region["height"])
    image = pixels[top:top + region["height"], region["x"]:region["x"] + region["width"]]
    # A rendered level, not an empty or black window: many distinct colours, a bright part.
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 200 and image.max() > 150
