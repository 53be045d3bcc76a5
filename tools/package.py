"""./raylab package: raylab as users install it.

    out/wheels/raylab_core-<version>-cp3XX-cp3XX-manylinux_2_34_x86_64.whl
        the native core for one Python (`raylab_core._raylab`, its TBB beside it in raylab_core/libs/)
        with the plain-Python library `raylab`: `pip install` it into any Python of that version and
        `import raylab` works, no Blender needed.
    out/raylab-<version>-linux-x64.zip
        the extension for Blender 4.2 and later: the add-on, the levels and those wheels, listed under
        `wheels` in blender_manifest.toml. Made and checked by Blender's own `extension build` and
        `extension validate` (a Blender 4.2+ here, or the cached sid root's 5.2); Blender installs the
        wheel that matches its Python.
    out/raylab-<version>-linux-arm64.zip, out/wheels/...manylinux_2_34_aarch64.whl (with --arm64)
        the same for Linux arm64, from the module ./raylab test --arch arm64 cross-built and tested; each
        extension's manifest lists its one platform and only that platform's wheels.
    out/raylab-<version>-addon-linux-x64.zip
        the legacy add-on for Blender 3.x (a raylab/ folder, the modules loose in it, libs/cpXY/).

Every shipped library is self-contained the way manylinux wheels are: what the module needs beyond
glibc, libstdc++ and Python is copied beside it, renamed with a hash of its contents (so that it never
clashes with a library of the same name Blender loaded first) and found through an $ORIGIN run path.
OpenImageIO is not among them: it lives in `_raylab_images`, which is left out (api.write_image goes
through Blender's writer instead).

One build host makes every module: the Python running this script from the normal build, and with
--all-pythons the other Pythons of the Blenders raylab serves, compiled here against the headers (Python
and pybind11) of the cached Debian root that has that Python. A CPython extension does not link
libpython, so the host's glibc and libstdc++ alone decide what the modules need: GLIBC_BASELINE.
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
ROOTS = os.environ.get("RAYLAB_ROOTS", "/var/cache/raylab")
SKIP_DIRS = {"__pycache__"}
# What every Linux with a Blender has: the C library, the C++ runtime, the loader, Python itself.
BASE_LIBRARIES = re.compile(r"^(linux-vdso|ld-linux.*|libc|libm|libpthread|libdl|librt|libstdc\+\+|libgcc_s|"
                            r"libpython\d\.\d+)\.so")
# The Linux architectures raylab's wheels are built for: Blender's platform name, the objdump that reads
# their symbol versions, and for one that is not the host's the cached root (tools/debian_root.sh, run
# through qemu-user) whose loader resolves its libraries. ELF_MACHINES: e_machine in an ELF header.
ARCHES = {"x86_64": {"platform": "linux-x64", "objdump": "objdump", "root": None},
          "aarch64": {"platform": "linux-arm64", "objdump": "aarch64-linux-gnu-objdump", "root": "debian12-arm64"}}
ELF_MACHINES = {0x3E: "x86_64", 0xB7: "aarch64"}
PLATFORM = ARCHES["x86_64"]["platform"]  # the host's: the legacy add-on's, the release's
# The arm64 module as ./raylab test --arch arm64 cross-builds (for the arm64 root's Python 3.11).
ARM64_MODULE = os.path.join(ROOT, "build-arm64", "addon", "raylab", "_raylab.cpython-311-aarch64-linux-gnu.so")
# The newest symbol versions any shipped library may need (Debian 12's toolchain: glibc 2.36 whose
# pthread symbols moved into libc in 2.34, GCC 12's libstdc++ used up to GCC 11's symbols). Systems at or
# above it: Debian 12+, Ubuntu 22.04+, RHEL/Rocky 9+, Fedora 35+. The README states it; tests check both.
GLIBC_BASELINE = (2, 34)
GLIBCXX_BASELINE = (3, 4, 29)
WHEEL_PLATFORM = f"manylinux_{GLIBC_BASELINE[0]}_{GLIBC_BASELINE[1]}_x86_64"
# The Pythons of the Blenders raylab serves (official 4.2-5.0: 3.11, official 5.1+: 3.13, Debian sid's
# 5.2: 3.14) and the cached root (tools/debian_root.sh) whose headers build each one on another host.
PYTHON_ROOTS = {"3.11": None, "3.13": "debian13", "3.14": "sid"}
# Bundled code and data, credited in the extension's manifest (licences in the README).
COPYRIGHT = ["2025-2026 raylab developers",
             "2005-2021 Intel Corporation (oneTBB, Apache-2.0)",
             "2012 Lee Perry-Smith (goat head mesh, CC BY 3.0)"]
WEBSITE = "https://github.com/raylab-dev/raylab"
# What an installed raylab must do (tests/release, the arm64 wheel in its root): every structure finds a
# triangle's hit; it prints where raylab and its core were loaded from.
TRACE_CHECK = ("import numpy as np, raylab; "
               "v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32); t = np.array([[0, 1, 2]], np.uint32); "
               "h = [raylab.build(v, t, structure=s).intersect(np.array([[0.2, 0.2, 1]], np.float32), "
               "np.array([[0, 0, -1]], np.float32)) for s in raylab.STRUCTURES]; "
               "assert all(x.hit[0] and abs(x.t[0] - 1) < 1e-6 for x in h); "
               "print('TRACED', raylab.__file__, raylab.native.core.__file__, np.__version__)")


def python_tag(version=sys.version_info):
    return f"cp{version[0]}{version[1]}"


def tag_of(version):
    """"3.13" -> "cp313"."""
    major, minor = version.split(".")
    return f"cp{major}{minor}"


def addon_version():
    """bl_info["version"] of addon/raylab/__init__.py, read without importing the package."""
    tree = ast.parse(open(os.path.join(ADDON, "__init__.py")).read())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "bl_info" for t in node.targets):
            return ".".join(map(str, ast.literal_eval(node.value)["version"]))
    raise SystemExit("package: no bl_info in addon/raylab/__init__.py")


def elf_arch(path):
    """"x86_64" or "aarch64": the machine an ELF file is built for (its header's e_machine)."""
    with open(path, "rb") as file:
        header = file.read(20)
    if header[:4] != b"\x7fELF" or int.from_bytes(header[18:20], "little") not in ELF_MACHINES:
        raise SystemExit(f"package: {path} is not an ELF file of {', '.join(ARCHES)}")
    return ELF_MACHINES[int.from_bytes(header[18:20], "little")]


def ldd(path):
    """(ldd's output for `path`, the folder its paths are relative to): the host's ldd, or for another
    architecture the one of its root, run there (qemu-user); `path` must then lie inside the checkout."""
    root = ARCHES[elf_arch(path)]["root"]
    if root is None:
        return subprocess.run(["ldd", path], capture_output=True, text=True, check=True).stdout, ""
    inside = "/raylab/" + os.path.relpath(os.path.abspath(path), ROOT)
    run = subprocess.run([os.path.join(ROOT, "tools", "debian_root.sh"), "run", root, "ldd", inside],
                         capture_output=True, text=True, check=True)
    return run.stdout, os.path.join(ROOTS, root)


def linked_libraries(path):
    """{soname: resolved path} of everything `path` loads (ldd: the whole closure); exits on 'not found'."""
    output, prefix = ldd(path)
    libraries = {}
    for line in output.splitlines():
        match = re.match(r"\s*(\S+) => (.*?)(?: \(0x[0-9a-f]+\))?$", line)
        if not match:
            continue
        name, target = match.groups()
        if target == "not found":
            raise SystemExit(f"package: {os.path.basename(path)} needs {name}, which is not installed")
        libraries[name] = prefix + target
    return libraries


def symbol_versions(path):
    """{"GLIBC": (2, 34), "GLIBCXX": (3, 4, 29), ...}: the newest version of each library's symbols that
    the ELF file `path` needs (objdump's dynamic symbol table)."""
    objdump = ARCHES[elf_arch(path)]["objdump"]
    output = subprocess.run([objdump, "-T", path], capture_output=True, text=True, check=True).stdout
    newest = {}
    for library, version in re.findall(r"\b(GLIBC|GLIBCXX|CXXABI)_(\d+(?:\.\d+)*)\b", output):
        number = tuple(int(part) for part in version.split("."))
        newest[library] = max(newest.get(library, number), number)
    return newest


def above_baseline(needs):
    """What symbol_versions' `needs` ask beyond GLIBC_BASELINE / GLIBCXX_BASELINE, as text ("" when nothing)."""
    over = [f"{library}_{'.'.join(map(str, needs[library]))}"
            for library, baseline in (("GLIBC", GLIBC_BASELINE), ("GLIBCXX", GLIBCXX_BASELINE))
            if needs.get(library, ()) > baseline]
    return ", ".join(over)


def patchelf(*args):
    subprocess.run(["patchelf", *args], check=True)


def bundle(module, folder, libs, release):
    """Copies `module` into `folder` with the libraries it needs beyond the base system in folder/libs
    (the relative path `libs`), renamed by content hash and found through $ORIGIN. A release build
    (the one build host's) refuses a library above the baseline. Returns ({soname: bundled}, the newest
    GLIBC version any of them needs)."""
    if shutil.which("patchelf") is None:
        raise SystemExit("package: patchelf is missing (Debian package patchelf): run ./raylab setup")
    os.makedirs(os.path.join(folder, libs), exist_ok=True)
    staged = os.path.join(folder, os.path.basename(module))
    shutil.copy2(module, staged)
    renamed = {}
    for soname, source in sorted(linked_libraries(module).items()):
        if BASE_LIBRARIES.match(soname):
            continue
        digest = hashlib.sha256(open(source, "rb").read()).hexdigest()[:8]
        stem, _, version = soname.partition(".so")
        renamed[soname] = f"{stem}-{digest}.so{version}"
        shutil.copy2(source, os.path.join(folder, libs, renamed[soname]))
    bundled = [os.path.join(folder, libs, name) for name in renamed.values()]
    for path in bundled:
        os.chmod(path, 0o755)
        patchelf("--set-soname", os.path.basename(path), path)
        patchelf("--set-rpath", "$ORIGIN", path)
    glibc = (2, 17)
    for path in [staged] + bundled:
        for soname, name in renamed.items():
            patchelf("--replace-needed", soname, name, path)
        needs = symbol_versions(path)
        glibc = max(glibc, needs.get("GLIBC", glibc))
        over = above_baseline(needs) if release else ""
        if over:
            raise SystemExit(f"package: {os.path.basename(path)} needs {over}, above the baseline "
                             f"GLIBC_{'.'.join(map(str, GLIBC_BASELINE))}: build on an older system")
    patchelf("--set-rpath", f"$ORIGIN/{libs}", staged)
    return renamed, glibc


def os_release():
    try:
        fields = dict(line.rstrip().split("=", 1) for line in open("/etc/os-release") if "=" in line)
        return fields.get("PRETTY_NAME", "").strip('"')
    except OSError:
        return "unknown"


# --- the modules -------------------------------------------------------------------------------------

def this_python_module():
    """The normal build's module for the Python running this script."""
    module = os.path.join(ADDON, "_raylab" + sysconfig.get_config_var("EXT_SUFFIX"))
    if not os.path.exists(module):
        raise SystemExit(f"package: {os.path.relpath(module, ROOT)} is missing: run ./raylab setup")
    return module


def root_headers(version):
    """The cached root holding Python `version`'s headers and pybind11's, or an exit saying how to get it."""
    name = PYTHON_ROOTS[version]
    root = os.path.join(ROOTS, name)
    needed = [f"usr/include/python{version}", f"usr/include/x86_64-linux-gnu/python{version}", "usr/include/pybind11"]
    missing = [path for path in needed if not os.path.isdir(os.path.join(root, path))]
    if missing:
        raise SystemExit(f"package: the module for Python {version} is built with the headers of the {name} "
                         f"root, which lacks {', '.join(missing)}: run ./raylab test --root {name} (or "
                         f"tools/debian_root.sh install {name} python3-dev pybind11-dev)")
    return root, needed


def other_python_module(version):
    """Builds the module for Python `version` on this host against a root's headers; returns its path."""
    root, headers = root_headers(version)
    tag = tag_of(version)
    work = os.path.join(ROOT, "build-wheels", tag)
    include = os.path.join(work, "include")
    shutil.rmtree(include, ignore_errors=True)
    for path in headers:  # only these folders: the root's own C library headers must stay out
        shutil.copytree(os.path.join(root, path), os.path.join(include, os.path.relpath(path, "usr/include")))
    suffix = f".cpython-{tag[2:]}-x86_64-linux-gnu.so"
    build = os.path.join(work, "build")
    if not os.path.exists(os.path.join(build, "build.ninja")):
        subprocess.run(["cmake", "-S", ROOT, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
                        f"-DRAYLAB_WHEEL_INCLUDE={include}", f"-DRAYLAB_WHEEL_SUFFIX={suffix}",
                        f"-DRAYLAB_MODULE_DIR={os.path.join(work, 'module')}"], check=True, stdout=subprocess.DEVNULL)
    subprocess.run(["cmake", "--build", build, "--target", "_raylab", "--", f"-j{os.cpu_count()}"], check=True,
                   stdout=subprocess.DEVNULL)
    return os.path.join(work, "module", "_raylab" + suffix)


def modules(all_pythons, arm64):
    """[(python version, module path)]: this Python's, with all_pythons every other one raylab serves on
    x86-64, with arm64 the arm64 root's (3.11) as ./raylab test --arch arm64 built and tested it."""
    running = f"{sys.version_info[0]}.{sys.version_info[1]}"
    found = [(running, this_python_module())]
    if all_pythons:
        found += [(version, other_python_module(version)) for version in PYTHON_ROOTS if version != running]
    if arm64:
        if not os.path.exists(ARM64_MODULE):
            raise SystemExit(f"package: {os.path.relpath(ARM64_MODULE, ROOT)} is missing: "
                             "run ./raylab test --arch arm64")
        found.append(("3.11", ARM64_MODULE))
    return sorted(found)


# --- the wheels --------------------------------------------------------------------------------------

def library_files():
    """The plain-Python library `raylab`: the add-on folder's top-level modules (blender/ is the add-on)."""
    return sorted(name for name in os.listdir(ADDON) if name.endswith(".py"))


def make_wheel(version, module, out_dir, release):
    """out/wheels/raylab_core-<version>-cpXY-cpXY-manylinux_A_B_ARCH.whl for one module, tagged with the
    glibc it needs (WHEEL_PLATFORM for a release; a root's own build, for its tests, needs its newer
    glibc and says so); returns its path and the bundled libraries."""
    tag = tag_of(version)
    stage = os.path.join(out_dir, "wheel-stage", f"{tag}-{elf_arch(module)}")
    shutil.rmtree(stage, ignore_errors=True)
    core = os.path.join(stage, "raylab_core")
    os.makedirs(core)
    renamed, glibc = bundle(module, core, "libs", release)
    platform = f"manylinux_{glibc[0]}_{glibc[1]}_{elf_arch(module)}"
    with open(os.path.join(core, "__init__.py"), "w") as file:
        file.write('"""raylab\'s native core (`raylab_core._raylab`); the API is `import raylab`."""\n')
    os.makedirs(os.path.join(stage, "raylab"))
    for name in library_files():
        shutil.copy2(os.path.join(ADDON, name), os.path.join(stage, "raylab", name))
    number = addon_version()
    info = os.path.join(stage, f"raylab_core-{number}.dist-info")
    os.makedirs(info)
    with open(os.path.join(info, "METADATA"), "w") as file:
        file.write(f"Metadata-Version: 2.1\nName: raylab_core\nVersion: {number}\n"
                   "Summary: See and measure ray-tracing acceleration structures (raylab's core and Python API)\n"
                   f"Home-page: {WEBSITE}\nLicense: GPL-3.0-or-later\nRequires-Python: =={version}.*\n"
                   "Requires-Dist: numpy\n")
    with open(os.path.join(info, "WHEEL"), "w") as file:
        file.write(f"Wheel-Version: 1.0\nGenerator: raylab package.py\nRoot-Is-Purelib: false\n"
                   f"Tag: {tag}-{tag}-{platform}\n")
    wheels = os.path.join(out_dir, "wheels")
    os.makedirs(wheels, exist_ok=True)
    target = os.path.join(wheels, f"raylab_core-{number}-{tag}-{tag}-{platform}.whl")
    if os.path.exists(target):
        os.remove(target)
    subprocess.run([sys.executable, "-m", "wheel", "pack", stage, "-d", wheels], check=True,
                   stdout=subprocess.DEVNULL)
    if not os.path.exists(target):
        raise SystemExit(f"package: wheel pack did not write {target}")
    return target, renamed


# --- the extension and the legacy add-on -------------------------------------------------------------

def wheel_platform(wheel):
    """Blender's platform name of a wheel: "linux-x64" for ..._x86_64.whl, "linux-arm64" for ..._aarch64.whl."""
    return ARCHES[re.search(rf"_({'|'.join(ARCHES)})\.whl$", wheel)[1]]["platform"]


def manifest(version, wheels, platform):
    """blender_manifest.toml (schema 1.0.0) of the extension for `platform`, with its wheels."""
    listed = ",\n  ".join(f'"./wheels/{os.path.basename(w)}"' for w in wheels)
    copyright_lines = ",\n  ".join(f'"{line}"' for line in COPYRIGHT)
    return f'''schema_version = "1.0.0"

id = "raylab"
version = "{version}"
name = "raylab"
tagline = "See and measure ray-tracing acceleration structures"
maintainer = "raylab developers"
type = "add-on"
website = "{WEBSITE}"
tags = ["Render", "3D View"]

blender_version_min = "4.2.0"
license = ["SPDX:GPL-3.0-or-later"]
copyright = [
  {copyright_lines},
]
platforms = ["{platform}"]
# The native core, one wheel per Python (Blender installs the one matching its own).
wheels = [
  {listed},
]

[permissions]
files = "Reads mesh files and writes rendered images and charts"
'''


def tree_files(source, skip=lambda name: False):
    """(path, path relative to source) of every file below `source`, in order, but SKIP_DIRS and `skip`."""
    for folder, dirs, files in os.walk(source):
        dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS)
        for name in sorted(files):
            path = os.path.join(folder, name)
            relative = os.path.relpath(path, source)
            if not skip(relative):
                yield path, relative


def add_tree(zf, source, arcroot, skip=lambda name: False):
    for path, relative in tree_files(source, skip):
        zf.write(path, os.path.join(arcroot, relative))


def copy_tree(source, target, skip=lambda name: False):
    for path, relative in tree_files(source, skip):
        os.makedirs(os.path.dirname(os.path.join(target, relative)), exist_ok=True)
        shutil.copy2(path, os.path.join(target, relative))


def development_file(relative):
    """The development build's modules and their staged libraries: never shipped as they are."""
    return re.fullmatch(r"_raylab(_images)?\..*\.so", relative) is not None or relative.startswith("libs/")


def blender_version():
    """(major, minor) of the `blender` on PATH, or None without one."""
    if shutil.which("blender") is None:
        return None
    line = subprocess.run(["blender", "--version"], capture_output=True, text=True, check=True).stdout.split("\n")[0]
    return tuple(int(part) for part in line.split()[1].split(".")[:2])


def extension_blender(paths):
    """How to run a Blender 4.2+ with `paths` visible: (command prefix, path mapper), or None. Blender here
    when it is 4.2+, else the cached sid root's (the checkout is /raylab there)."""
    if (blender_version() or (0, 0)) >= (4, 2):
        return ["blender"], lambda path: path
    sid = os.path.join(ROOTS, PYTHON_ROOTS["3.14"])
    inside = all(os.path.abspath(p).startswith(ROOT + os.sep) for p in paths)
    if inside and os.path.exists(os.path.join(sid, "usr/bin/blender")) and os.geteuid() == 0:
        return ([os.path.join(ROOT, "tools", "debian_root.sh"), "run", PYTHON_ROOTS["3.14"], "blender"],
                lambda path: "/raylab/" + os.path.relpath(os.path.abspath(path), ROOT))
    return None


def build_extension(out_dir, version, wheels, platform):
    """Stages the extension for `platform` and has Blender build and validate it; returns (zip, validate's
    output or None)."""
    stage = os.path.join(out_dir, "extension-stage", platform)
    shutil.rmtree(stage, ignore_errors=True)
    copy_tree(ADDON, stage, skip=development_file)
    if os.path.isdir(LEVELS):
        copy_tree(LEVELS, os.path.join(stage, "levels"))
    shutil.copy2(os.path.join(ROOT, "README.md"), os.path.join(stage, "README.md"))  # the Documentation button
    os.makedirs(os.path.join(stage, "wheels"))
    for wheel in wheels:
        shutil.copy2(wheel, os.path.join(stage, "wheels"))
    with open(os.path.join(stage, "blender_manifest.toml"), "w") as file:
        file.write(manifest(version, wheels, platform))
    target = os.path.join(out_dir, f"raylab-{version}-{platform}.zip")
    if os.path.exists(target):
        os.remove(target)
    blender = extension_blender([stage, target])
    if blender is None:  # no Blender 4.2+ reachable: the same files, zipped here, not validated
        with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as zf:
            add_tree(zf, stage, "")
        return target, None
    command, mapped = blender
    base = command + ["-b", "--factory-startup", "--command", "extension"]
    run = subprocess.run(base + ["build", "--source-dir", mapped(stage), "--output-filepath", mapped(target)],
                         capture_output=True, text=True)
    if run.returncode != 0 or not os.path.exists(target):
        raise SystemExit(f"package: blender --command extension build failed:\n{run.stdout}{run.stderr}")
    run = subprocess.run(base + ["validate", mapped(target)], capture_output=True, text=True)
    # Blender's own lines only, not the sound and file-system warnings of a machine without them.
    noise = re.compile(r"pw\.conf|ALSOFT|mounted file-systems|^Blender \d")
    report = "\n".join(line for line in (run.stdout + run.stderr).splitlines()
                       if line.strip() and not noise.search(line))
    if run.returncode != 0:
        raise SystemExit(f"package: blender --command extension validate failed:\n{report}")
    return target, report


def write_legacy(out_dir, version, modules_by_version):
    """The add-on zip for Blender 3.x (x86-64: no Blender 3.x of another platform is served): the modules
    loose in raylab/, their libraries in libs/cpXY/."""
    stage = os.path.join(out_dir, "legacy-stage")
    shutil.rmtree(stage, ignore_errors=True)
    for version_, module in modules_by_version:
        bundle(module, stage, f"libs/{tag_of(version_)}", release=False)
    target = os.path.join(out_dir, f"raylab-{version}-addon-{PLATFORM}.zip")
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as zf:
        add_tree(zf, ADDON, "raylab", skip=development_file)
        add_tree(zf, stage, "raylab")
        if os.path.isdir(LEVELS):
            add_tree(zf, LEVELS, "raylab/levels")
        zf.write(os.path.join(ROOT, "README.md"), "raylab/README.md")
    return target


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=os.path.join(ROOT, "out"), help="folder of the packages (default out/)")
    parser.add_argument("--all-pythons", action="store_true",
                        help=f"also build the modules of Python {', '.join(PYTHON_ROOTS)} with the cached roots' "
                             "headers")
    parser.add_argument("--arm64", action="store_true",
                        help="also the Linux arm64 wheel and extension, from the module that "
                             "./raylab test --arch arm64 built")
    args = parser.parse_args()
    out_dir = os.path.abspath(args.out)
    version = addon_version()
    found = modules(args.all_pythons, args.arm64)
    if os.path.isdir(os.path.join(out_dir, "wheels")):
        shutil.rmtree(os.path.join(out_dir, "wheels"))
    wheels = []
    for python, module in found:
        wheel, renamed = make_wheel(python, module, out_dir, release=args.all_pythons)
        wheels.append(wheel)
        needs = symbol_versions(module)
        print(f"package: {os.path.basename(wheel)} (Python {python}; needs "
              + ", ".join(f"{k}_{'.'.join(map(str, v))}" for k, v in sorted(needs.items()))
              + f"; bundles {', '.join(renamed.values()) or 'nothing'})")
    extensions = {}  # one per platform built, each listing that platform and its wheels only
    for platform in sorted({wheel_platform(w) for w in wheels}):
        mine = [w for w in wheels if wheel_platform(w) == platform]
        extension, report = build_extension(out_dir, version, mine, platform)
        extensions[platform] = {"zip": os.path.basename(extension), "validate": report,
                                "wheels": [os.path.basename(w) for w in mine]}
        print(f"package: {platform} extension validate: "
              f"{report if report is not None else 'not run (no Blender 4.2+ here)'}")
        print(f"package: wrote {extension} ({os.path.getsize(extension) / 1e6:.1f} MB)")
    legacy = write_legacy(out_dir, version, [(v, m) for v, m in found if elf_arch(m) == "x86_64"])
    print(f"package: wrote {legacy} ({os.path.getsize(legacy) / 1e6:.1f} MB)")
    host = extensions[PLATFORM]
    with open(os.path.join(out_dir, "package.json"), "w") as file:
        json.dump({"version": version, "wheels": [os.path.basename(w) for w in wheels],
                   "extension": host["zip"], "validate": host["validate"], "extensions": extensions,
                   "legacy": os.path.basename(legacy), "system": os_release()}, file, indent=2)


if __name__ == "__main__":
    main()
