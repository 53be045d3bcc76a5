"""Writes out/raylab-addon.zip: the add-on folder (with its native module and shipped meshes) and the
levels, installable through Blender's Preferences > Add-ons > Install."""
import os
import sys
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ADDON = os.path.join(ROOT, "addon", "raylab")
LEVELS = os.path.join(ROOT, "levels")
SKIP_DIRS = {"__pycache__"}


def add_tree(zf, source, arcroot):
    for folder, dirs, files in os.walk(source):
        dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS)
        for name in sorted(files):
            path = os.path.join(folder, name)
            zf.write(path, os.path.join(arcroot, os.path.relpath(path, source)))


def main():
    if not any(n.startswith("_raylab") and n.endswith(".so") for n in os.listdir(ADDON)):
        sys.exit("package: the native module is missing from addon/raylab: run ./raylab setup")
    out_dir = os.path.join(ROOT, "out")
    os.makedirs(out_dir, exist_ok=True)
    target = os.path.join(out_dir, "raylab-addon.zip")
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as zf:
        add_tree(zf, ADDON, "raylab")
        if os.path.isdir(LEVELS):
            add_tree(zf, LEVELS, "raylab/levels")
    print(f"package: wrote {target} ({os.path.getsize(target) / 1e6:.1f} MB)")


if __name__ == "__main__":
    main()
