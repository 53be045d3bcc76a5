"""./raylab package: the add-on as a Blender extension (4.2+) and as a legacy add-on zip (3.x).

    out/raylab-<version>-linux-x64.zip         extension: blender_manifest.toml at the top, install with
                                               Edit > Preferences > Get Extensions > Install from Disk
    out/raylab-<version>-addon-linux-x64.zip   legacy add-on (a raylab/ folder): Preferences > Add-ons > Install

Both carry the native module `_raylab` of every Python it was staged for, each self-contained the way
manylinux wheels are: the shared libraries it needs beyond glibc, libstdc++ and Python (TBB,
tinyobjloader) are copied to libs/cpXY/, renamed with a hash of their contents so that they never clash
with a library of the same name that Blender loaded first, and found through an $ORIGIN run path.
OpenImageIO is not among them: it lives in `_raylab_images`, which is left out (api.write_image goes
through Blender's writer instead).

Staging runs for the Python that runs this script (/usr/bin/python3, Blender's Python on Debian) and
keeps its result in out/native/cpXY/, so packaging once on Debian 12 (Python 3.11) and once in the
Debian 13 root (3.13) gives zips that work in both Blenders.
"""
import argparse
import ast
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ADDON = os.path.join(ROOT, "addon", "raylab")
LEVELS = os.path.join(ROOT, "levels")
SKIP_DIRS = {"__pycache__"}
# What every Linux with a Blender has: the C library, the C++ runtime, the loader, Python itself.
BASE_LIBRARIES = re.compile(r"^(linux-vdso|ld-linux.*|libc|libm|libpthread|libdl|librt|libstdc\+\+|libgcc_s|"
                            r"libpython\d\.\d+)\.so")
PLATFORM = "linux-x64"


def python_tag(version=sys.version_info):
    return f"cp{version[0]}{version[1]}"


def addon_version():
    """bl_info["version"] of addon/raylab/__init__.py, read without importing the package."""
    tree = ast.parse(open(os.path.join(ADDON, "__init__.py")).read())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "bl_info" for t in node.targets):
            return ".".join(map(str, ast.literal_eval(node.value)["version"]))
    raise SystemExit("package: no bl_info in addon/raylab/__init__.py")


def linked_libraries(path):
    """{soname: resolved path} of everything `path` loads (ldd: the whole closure); exits on 'not found'."""
    output = subprocess.run(["ldd", path], capture_output=True, text=True, check=True).stdout
    libraries = {}
    for line in output.splitlines():
        match = re.match(r"\s*(\S+) => (.*?)(?: \(0x[0-9a-f]+\))?$", line)
        if not match:
            continue
        name, target = match.groups()
        if target == "not found":
            raise SystemExit(f"package: {os.path.basename(path)} needs {name}, which is not installed")
        libraries[name] = target
    return libraries


def patchelf(*args):
    subprocess.run(["patchelf", *args], check=True)


def stage_native(out_dir):
    """Copies this Python's _raylab module with its libraries into out/native/cpXY/; returns that folder."""
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    module = os.path.join(ADDON, "_raylab" + suffix)
    if not os.path.exists(module):
        raise SystemExit(f"package: {os.path.relpath(module, ROOT)} is missing: run ./raylab setup")
    if shutil.which("patchelf") is None:
        raise SystemExit("package: patchelf is missing (Debian package patchelf): run ./raylab setup")
    tag = python_tag()
    stage = os.path.join(out_dir, "native", tag)
    shutil.rmtree(stage, ignore_errors=True)
    libs = os.path.join(stage, "libs", tag)
    os.makedirs(libs)
    staged_module = os.path.join(stage, os.path.basename(module))
    shutil.copy2(module, staged_module)

    renamed = {}  # soname -> bundled file name
    for soname, source in sorted(linked_libraries(module).items()):
        if BASE_LIBRARIES.match(soname):
            continue
        digest = hashlib.sha256(open(source, "rb").read()).hexdigest()[:8]
        stem, dot, version = soname.partition(".so")
        renamed[soname] = f"{stem}-{digest}.so{version}"
        shutil.copy2(source, os.path.join(libs, renamed[soname]))
    for soname, bundled in renamed.items():
        path = os.path.join(libs, bundled)
        os.chmod(path, 0o755)
        patchelf("--set-soname", bundled, path)
        patchelf("--set-rpath", "$ORIGIN", path)
    for path in [staged_module] + [os.path.join(libs, b) for b in renamed.values()]:
        for soname, bundled in renamed.items():
            patchelf("--replace-needed", soname, bundled, path)
    patchelf("--set-rpath", f"$ORIGIN/libs/{tag}", staged_module)
    with open(os.path.join(stage, "build.json"), "w") as file:
        json.dump({"python": f"{sys.version_info[0]}.{sys.version_info[1]}", "module": os.path.basename(module),
                   "libraries": renamed, "system": os_release()}, file, indent=2)
    return stage


def os_release():
    try:
        fields = dict(line.rstrip().split("=", 1) for line in open("/etc/os-release") if "=" in line)
        return fields.get("PRETTY_NAME", "").strip('"')
    except OSError:
        return "unknown"


def staged_builds(out_dir):
    """Every staged native build in out/native, newest Python first: [(tag, folder, build.json)]."""
    root = os.path.join(out_dir, "native")
    builds = []
    for tag in sorted(os.listdir(root), reverse=True):
        info = os.path.join(root, tag, "build.json")
        if os.path.exists(info):
            builds.append((tag, os.path.join(root, tag), json.load(open(info))))
    return builds


def manifest(version, pythons):
    """blender_manifest.toml (schema 1.0.0) of the extension."""
    return f'''schema_version = "1.0.0"

id = "raylab"
version = "{version}"
name = "raylab"
tagline = "See and measure ray-tracing acceleration structures"
maintainer = "raylab developers"
type = "add-on"
tags = ["Render", "3D View"]

# The native module is built for Python {" and ".join(pythons)}; in a Blender with another Python the
# add-on's preferences say which build it needs.
blender_version_min = "4.2.0"
license = ["SPDX:GPL-3.0-or-later"]
platforms = ["{PLATFORM}"]

[permissions]
files = "Reads mesh files and writes rendered images"
'''


def add_tree(zf, source, arcroot, skip=lambda name: False):
    for folder, dirs, files in os.walk(source):
        dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS)
        for name in sorted(files):
            path = os.path.join(folder, name)
            if not skip(os.path.relpath(path, source)):
                zf.write(path, os.path.join(arcroot, os.path.relpath(path, source)))


def write_zip(target, arcroot, builds, extra=None):
    """The add-on folder without the development build's modules, the staged modules, the levels, the README."""
    def development_module(relative):
        return re.fullmatch(r"_raylab(_images)?\..*\.so", relative) is not None

    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as zf:
        add_tree(zf, ADDON, arcroot, skip=development_module)
        for _, folder, _ in builds:
            add_tree(zf, folder, arcroot, skip=lambda relative: relative == "build.json")
        if os.path.isdir(LEVELS):
            add_tree(zf, LEVELS, os.path.join(arcroot, "levels"))
        # The Preferences' Documentation button opens it.
        zf.write(os.path.join(ROOT, "README.md"), os.path.join(arcroot, "README.md"))
        for name, text in (extra or {}).items():
            zf.writestr(os.path.join(arcroot, name), text)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=os.path.join(ROOT, "out"), help="folder of the zips (default out/)")
    args = parser.parse_args()
    out_dir = os.path.abspath(args.out)
    stage_native(out_dir)
    builds = staged_builds(out_dir)
    version = addon_version()
    pythons = [info["python"] for _, _, info in builds]
    extension = os.path.join(out_dir, f"raylab-{version}-{PLATFORM}.zip")
    legacy = os.path.join(out_dir, f"raylab-{version}-addon-{PLATFORM}.zip")
    write_zip(extension, "", builds, extra={"blender_manifest.toml": manifest(version, pythons)})
    write_zip(legacy, "raylab", builds)
    for _, _, info in builds:
        print(f"package: native module for Python {info['python']} ({info['system']}), bundling "
              f"{', '.join(info['libraries'].values()) or 'nothing'}")
    for path in (extension, legacy):
        print(f"package: wrote {path} ({os.path.getsize(path) / 1e6:.1f} MB)")


if __name__ == "__main__":
    main()
