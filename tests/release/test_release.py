"""What a user downloads, as ./raylab test --release made it in out/ (tools/package.py --all-pythons): the
wheels within the glibc baseline the README states, the extension Blender built and validated, the same
wheel installed with pip, and the host-built modules loaded by the real Blenders of the cached roots."""
import json
import os
import re
import subprocess
import sys
import zipfile

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "out")
sys.path.insert(0, os.path.join(ROOT, "tools"))
import package  # noqa: E402

TRACE = package.TRACE_CHECK


@pytest.fixture(scope="module")
def packaged():
    path = os.path.join(OUT, "package.json")
    assert os.path.exists(path), "no out/package.json: run ./raylab test --release (tools/package.py --all-pythons)"
    info = json.load(open(path))
    info["wheel_paths"] = [os.path.join(OUT, "wheels", name) for name in info["wheels"]]
    return info


def readme_baseline():
    """The baseline as the README states it: "glibc baseline: GLIBC_2.34 and GLIBCXX_3.4.29"."""
    text = open(os.path.join(ROOT, "README.md")).read()
    match = re.search(r"glibc\s+baseline[^.]*?GLIBC_(\d+)\.(\d+)\D+GLIBCXX_(\d+)\.(\d+)\.(\d+)", text)
    assert match, "the README does not state the glibc baseline (GLIBC_x.y and GLIBCXX_x.y.z)"
    numbers = tuple(map(int, match.groups()))
    return numbers[:2], numbers[2:]


def wheel_libraries(wheel, folder):
    with zipfile.ZipFile(wheel) as zf:
        zf.extractall(folder)
    return sorted(os.path.join(d, f) for d, _, files in os.walk(folder) for f in files if ".so" in f)


def test_a_wheel_for_every_python_an_official_or_debian_blender_runs(packaged):
    tags = {re.search(r"-(cp3\d+)-cp3\d+-", name)[1] for name in packaged["wheels"]}
    assert tags == {package.tag_of(v) for v in package.PYTHON_ROOTS}, packaged["wheels"]
    for name in packaged["wheels"]:
        assert name.endswith(f"-{package.WHEEL_PLATFORM}.whl"), name


def test_every_shipped_library_needs_no_glibc_above_the_readmes_baseline(packaged, tmp_path):
    glibc, glibcxx = readme_baseline()
    assert (glibc, glibcxx) == (package.GLIBC_BASELINE, package.GLIBCXX_BASELINE), \
        "the README and tools/package.py state different baselines"
    assert package.WHEEL_PLATFORM == f"manylinux_{glibc[0]}_{glibc[1]}_x86_64"
    table = []
    for wheel in packaged["wheel_paths"]:
        libraries = wheel_libraries(wheel, tmp_path / os.path.basename(wheel))
        assert any("_raylab.cpython" in path for path in libraries) and any("libtbb" in path for path in libraries)
        for path in libraries:
            needs = package.symbol_versions(path)
            table.append(f"{os.path.basename(wheel)[:28]} {os.path.basename(path):45} "
                         + " ".join(f"{k}_{'.'.join(map(str, v))}" for k, v in sorted(needs.items())))
            assert needs.get("GLIBC", ()) <= glibc, (path, needs)
            assert needs.get("GLIBCXX", ()) <= glibcxx, (path, needs)
    print("\n" + "\n".join(table))


def test_the_extension_is_built_and_validated_by_blender_and_lists_its_wheels(packaged):
    import tomllib
    assert packaged["validate"] is not None, "extension validate did not run (no Blender 4.2+ reachable)"
    assert "error" not in packaged["validate"].lower(), packaged["validate"]
    with zipfile.ZipFile(os.path.join(OUT, packaged["extension"])) as zf:
        names = zf.namelist()
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode())
    assert sorted(os.path.basename(w) for w in manifest["wheels"]) == sorted(packaged["wheels"])
    assert all(w.lstrip("./") in names for w in manifest["wheels"])
    # Native code only inside the wheels: no loose module, no hand-made libs/ folder.
    assert not [n for n in names if n.endswith(".so") or ".so." in n or n.startswith("libs/")], names
    assert manifest["copyright"] and manifest["website"] and manifest["permissions"]["files"]
    assert manifest["platforms"] == [package.PLATFORM] and manifest["blender_version_min"] == "4.2.0"
    assert "levels/octree_2/level.toml" in names and "__init__.py" in names


def test_the_wheel_installs_with_pip_and_import_raylab_traces_outside_the_checkout(packaged, tmp_path):
    tag = package.python_tag()
    wheel = next(w for w in packaged["wheel_paths"] if f"-{tag}-" in w)
    venv = tmp_path / "venv"
    # Debian's numpy through the system site: pip reaches no package index here.
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    run = subprocess.run([str(venv / "bin" / "pip"), "install", "--no-index", "--no-deps", wheel],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    run = subprocess.run([str(venv / "bin" / "python"), "-c", TRACE], capture_output=True, text=True,
                         cwd=tmp_path, env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"})
    assert run.returncode == 0 and "TRACED" in run.stdout, run.stdout + run.stderr
    assert str(venv) in run.stdout and ROOT not in run.stdout, run.stdout


ROOT_BLENDERS = [name for name in package.PYTHON_ROOTS.values() if name]


@pytest.mark.parametrize("root", ROOT_BLENDERS)
def test_the_host_built_extension_installs_and_traces_in_the_roots_blender(packaged, root, tmp_path):
    """The extension zip from this host, installed with `extension install-file` into the root's own
    Blender (4.3 on Debian 13, 5.2 on sid), which must pick the wheel of its Python and trace with it."""
    work = os.path.join(ROOT, "out", "release-check", root)
    subprocess.run(["rm", "-rf", work], check=True)
    os.makedirs(work)
    inside = "/raylab/" + os.path.relpath(work, ROOT)
    script = os.path.join(work, "check.py")
    with open(script, "w") as file:
        file.write("import addon_utils, bpy, sys\n"
                   "addon_utils.enable('bl_ext.user_default.raylab', default_set=True, handle_error=print)\n"
                   "addon = sys.modules['bl_ext.user_default.raylab']\n"
                   "assert addon.native.ERROR is None, addon.native.ERROR\n"
                   f"exec({TRACE!r})\n")
    env = ["/usr/bin/env", f"BLENDER_USER_CONFIG={inside}/config", f"BLENDER_USER_SCRIPTS={inside}/scripts",
           f"BLENDER_USER_EXTENSIONS={inside}/extensions"]
    run_root = [os.path.join(ROOT, "tools", "debian_root.sh"), "run", root]
    zip_inside = "/raylab/out/" + packaged["extension"]
    run = subprocess.run(run_root + env + ["blender", "-b", "--command", "extension", "install-file", "-r",
                                           "user_default", "-e", zip_inside], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    run = subprocess.run(run_root + env + ["blender", "-b", "--python-exit-code", "1", "--python",
                                           f"{inside}/check.py"], capture_output=True, text=True)
    assert run.returncode == 0 and "TRACED" in run.stdout, run.stdout[-3000:] + run.stderr[-3000:]
    traced = next(line for line in run.stdout.splitlines() if line.startswith("TRACED"))
    assert "site-packages/raylab_core/_raylab.cpython" in traced, traced
    print(root, traced)
