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
import gui_util  # noqa: E402


@pytest.fixture(scope="module")
def packaged(tmp_path_factory):
    out = tmp_path_factory.mktemp("package")
    run = subprocess.run([sys.executable, os.path.join(ROOT, "tools", "package.py"), "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    version = package.addon_version()
    return {"extension": out / f"raylab-{version}-linux-x64.zip",
            "legacy": out / f"raylab-{version}-addon-linux-x64.zip"}


def test_extension_zip_has_a_valid_manifest_and_a_self_contained_module(packaged):
    import tomllib
    with zipfile.ZipFile(packaged["extension"]) as zf:
        names = zf.namelist()
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode())
    assert manifest["schema_version"] == "1.0.0" and manifest["id"] == "raylab" and manifest["type"] == "add-on"
    assert manifest["blender_version_min"] == "4.2.0" and manifest["platforms"] == ["linux-x64"]
    assert manifest["license"] and manifest["permissions"]["files"] and manifest["copyright"]
    if package.blender_version() >= (4, 2):  # Blender's own check of the manifest and the zip
        run = subprocess.run(["blender", "-b", "--factory-startup", "--command", "extension", "validate",
                              str(packaged["extension"])], capture_output=True, text=True, timeout=120)
        assert run.returncode == 0 and "FATAL" not in run.stdout + run.stderr, run.stdout + run.stderr
    # The native core only as this Python's wheel, listed in the manifest; no loose module, no libs/.
    tag = package.python_tag()
    listed = [os.path.basename(w) for w in manifest["wheels"] if f"-{tag}-{tag}-manylinux_" in w]
    assert len(listed) == 1 and f"wheels/{listed[0]}" in names, (manifest["wheels"], names)
    wheel = listed[0]
    assert not [name for name in names if name.endswith(".so") or name.startswith("libs/")], names
    with zipfile.ZipFile(zipfile.Path(packaged["extension"], f"wheels/{wheel}").open("rb")) as wf:
        inside = wf.namelist()
    assert f"raylab_core/_raylab.cpython-{tag[2:]}-x86_64-linux-gnu.so" in inside
    assert any(name.startswith("raylab_core/libs/libtbb-") for name in inside), inside
    # OpenImageIO stays out of what Blender loads; the development modules are not shipped.
    assert not any("_raylab_images" in name or "OpenImageIO" in name for name in names + inside)
    assert "__init__.py" in names and "levels/octree_2/level.toml" in names
    with zipfile.ZipFile(packaged["legacy"]) as zf:
        assert "raylab/__init__.py" in zf.namelist() and "raylab/blender_manifest.toml" not in zf.namelist()


@pytest.fixture(scope="module")
def session(packaged, tmp_path_factory):
    user = tmp_path_factory.mktemp("blender_user")
    env = dict(os.environ, BLENDER_USER_CONFIG=str(user / "config"), BLENDER_USER_SCRIPTS=str(user / "scripts"),
               BLENDER_USER_EXTENSIONS=str(user / "extensions"), BLENDER_USER_DATAFILES=str(user / "datafiles"))
    shots = tmp_path_factory.mktemp("shots")
    # Saved preferences without the splash: a first start would cover the window with Quick Setup.
    blend = shots / "empty.blend"
    subprocess.run(["blender", "-b", "--factory-startup", "--python-expr",
                    "import bpy; bpy.context.preferences.view.show_splash = False; bpy.ops.wm.save_userpref(); "
                    f"bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})"],
                   env=env, check=True, capture_output=True, timeout=120)
    if package.blender_version() >= (4, 2):
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
    report_path = shots / "report.json"
    run = gui_util.run_watched(["xvfb-run", "-a", "-s", "-screen 0 1600x900x24", "blender", str(blend),
                                "--python-exit-code", "1",
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


def test_a_build_for_another_python_says_which_python_it_needs(tmp_path):
    """The add-on installed with only a module for another Python (a stand-in named for Python 3.99):
    enabling it registers, with one message in the add-on's preferences and no traceback."""
    scripts = tmp_path / "scripts"
    target = scripts / "addons" / "raylab"
    shutil.copytree(os.path.join(ROOT, "addon", "raylab"), target,
                    ignore=shutil.ignore_patterns("_raylab*.so", "__pycache__"))
    (target / "_raylab.cpython-399-x86_64-linux-gnu.so").write_bytes(b"not a module for this Python")
    script = tmp_path / "enable.py"
    script.write_text(
        "import json, sys, addon_utils, bpy\n"
        "addon_utils.enable('raylab', default_set=True)\n"
        "addon = bpy.context.preferences.addons.get('raylab')\n"
        "print('REPORT' + json.dumps({'enabled': addon is not None,\n"
        "    'preferences': type(addon.preferences).__name__ if addon and addon.preferences else None,\n"
        "    'error': sys.modules['raylab'].native.ERROR,\n"
        "    'python': '%d.%d' % sys.version_info[:2]}))\n")
    env = dict(os.environ, BLENDER_USER_SCRIPTS=str(scripts), BLENDER_USER_CONFIG=str(tmp_path / "config"))
    run = subprocess.run(["blender", "-b", "--python-exit-code", "1", "--python", str(script)],
                         env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    report = json.loads(next(line[6:] for line in run.stdout.splitlines() if line.startswith("REPORT")))
    assert report["enabled"] and report["preferences"] == "RAYLAB_AP_native_missing"
    assert "built for Python 3.99" in report["error"] and f"runs Python {report['python']}" in report["error"]
    assert "Traceback" not in run.stdout + run.stderr
