"""The public CI's steps, one command each: .github/workflows/platforms.yml runs nothing but these, on
Linux x64 and arm64, Windows x64 and macOS arm64, against the official Blender 4.2, 4.5 and 5.2 LTS.

    python tools/platform_ci.py deps                   the build's libraries (apt, Homebrew or MSYS2)
    python tools/platform_ci.py blender 5.2            the official Blender 5.2 LTS for this platform,
                                                       downloaded to out/ci/ (--local EXE: one at hand)
    python tools/platform_ci.py build                  the core, its C++ tests and the module for the
                                                       Python running this script, which must be Blender's
    python tools/platform_ci.py test-cpp               the C++ tests (GoogleTest, through ctest)
    python tools/platform_ci.py test-python [ARGS]     the Python tests (pytest ARGS)
    python tools/platform_ci.py test-blender           the headless Blender tests in that Blender
    python tools/platform_ci.py package [ARGS]         the wheel and the extension (Linux: tools/package.py ARGS)

On this Debian host `./raylab test` runs the Linux job's steps itself, with Debian's Blender standing in for
the download (`blender --local`): `deps` is `./raylab setup`, the rest are called by run_tests. What cannot
run here is said where it is: the download (no internet), and the Windows and macOS branches of `deps` and
`build` (no such system).
"""
import argparse
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tarfile
import urllib.request
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STATE = os.path.join(ROOT, "out", "ci")
RELEASES = "https://download.blender.org/release"
# The Blender releases the public CI tests, with the Python their official builds run (one wheel each).
BLENDER_PYTHONS = {"4.2": "3.11", "4.5": "3.11", "5.2": "3.13"}
# Each platform's official archive (its name's ending on download.blender.org) and where Blender is in it.
# Blender publishes no official Linux arm64 build: that job tests the core and the module, not Blender.
ARCHIVES = {"linux-x64": ("linux-x64.tar.xz", "blender"),
            "windows-x64": ("windows-x64.zip", "blender.exe"),
            "macos-arm64": ("macos-arm64.dmg", "Blender.app/Contents/MacOS/Blender")}
# The build's libraries by platform. Windows builds with MinGW-w64's GCC (MSYS2, preinstalled on GitHub's
# Windows runners): the compiler this host cross-builds and tests with (tools/cross_windows.sh).
DEPENDENCIES = {
    "macos-arm64": ["brew", "install", "cmake", "ninja", "tbb", "glm", "pybind11", "openimageio", "googletest",
                    "nlohmann-json"],
    "windows-x64": ["C:/msys64/usr/bin/pacman.exe", "-S", "--noconfirm", "--needed"]
    + [f"mingw-w64-x86_64-{name}" for name in ("gcc", "cmake", "ninja", "tbb", "glm", "pybind11", "gtest",
                                                "nlohmann-json", "openimageio")],
}


def this_platform():
    """'linux-x64', 'linux-arm64', 'windows-x64' or 'macos-arm64': Blender's names for the platform."""
    system = {"Linux": "linux", "Windows": "windows", "Darwin": "macos"}.get(platform.system())
    machine = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "arm64": "arm64"}.get(platform.machine().lower())
    if system is None or machine is None:
        raise SystemExit(f"platform_ci: no raylab build for {platform.system()} {platform.machine()}")
    return f"{system}-{machine}"


def run(command, **kwargs):
    print("+", " ".join(map(str, command)), flush=True)
    return subprocess.run(command, **kwargs)


def saved_blender():
    """What the `blender` step recorded: {"executable", "version", "python"}."""
    path = os.path.join(STATE, "blender.json")
    if not os.path.exists(path):
        raise SystemExit("platform_ci: no Blender recorded: run `platform_ci.py blender VERSION` first")
    return json.load(open(path))


# --- deps --------------------------------------------------------------------------------------------

def deps(args):
    """The libraries the build needs, then numpy and pytest for the Python that builds, unless it is the
    system's (Debian's /usr/bin/python3 gets them from apt; the others from PyPI, which only the public CI
    reaches)."""
    where = this_platform()
    if where.startswith("linux"):
        rc = run(["bash", os.path.join(ROOT, "raylab"), "setup"]).returncode
    else:
        rc = run(DEPENDENCIES[where]).returncode
    if where == "windows-x64" and os.environ.get("GITHUB_PATH"):  # MinGW's gcc, cmake and DLLs for later steps
        with open(os.environ["GITHUB_PATH"], "a") as file:
            file.write("C:/msys64/mingw64/bin\n")
    if rc == 0 and os.path.realpath(sys.executable) != os.path.realpath("/usr/bin/python3"):
        rc = run([sys.executable, "-m", "pip", "install", "numpy", "pytest"]).returncode
    return rc


# --- blender -----------------------------------------------------------------------------------------

def newest_archive(listing, version, where):
    """The newest blender-<version>.N-<platform> archive named in a download.blender.org folder listing."""
    ending = ARCHIVES[where][0]
    found = re.findall(rf'href="(blender-{re.escape(version)}\.(\d+)-{re.escape(ending)})"', listing)
    if not found:
        raise SystemExit(f"platform_ci: no official Blender {version} for {where} in the listing")
    return max(found, key=lambda item: int(item[1]))[0]


def blender_python(executable):
    """(the Python version "3.11", its interpreter) inside the Blender `executable`, as Blender reports them."""
    out = subprocess.run([executable, "-b", "--factory-startup", "--python-expr",
                          "import sys; print('PYTHON %d.%d %s' % (*sys.version_info[:2], sys.executable))"],
                         capture_output=True, text=True, check=True).stdout
    match = re.search(r"^PYTHON (\d+\.\d+) (.+)$", out, re.M)
    if not match:
        raise SystemExit(f"platform_ci: {executable} did not report its Python:\n{out[-2000:]}")
    return match.group(1), match.group(2)


def download(version, where):
    """Downloads and unpacks the official Blender `version` for `where` into out/ci/; returns Blender."""
    folder = f"{RELEASES}/Blender{version}/"
    listing = urllib.request.urlopen(folder, timeout=60).read().decode()
    name = newest_archive(listing, version, where)
    archive = os.path.join(STATE, name)
    urllib.request.urlretrieve(folder + name, archive)
    target = os.path.join(STATE, f"blender-{version}")
    shutil.rmtree(target, ignore_errors=True)
    if name.endswith(".tar.xz"):
        with tarfile.open(archive) as tar:
            tar.extractall(target)
    elif name.endswith(".zip"):
        with zipfile.ZipFile(archive) as zf:
            zf.extractall(target)
    else:  # macOS: the disk image mounted, Blender.app copied out
        mount = os.path.join(STATE, "dmg")
        run(["hdiutil", "attach", "-nobrowse", "-mountpoint", mount, archive], check=True)
        try:
            shutil.copytree(os.path.join(mount, "Blender.app"), os.path.join(target, "Blender.app"), symlinks=True)
        finally:
            run(["hdiutil", "detach", mount], check=True)
    inner = ARCHIVES[where][1]
    for folder_, _, _ in os.walk(target):
        if os.path.isfile(os.path.join(folder_, inner)):
            return os.path.join(folder_, inner)
    raise SystemExit(f"platform_ci: {name} holds no {inner}")


def blender(args):
    """Records the Blender the next steps use: the official `version` downloaded, or --local EXE."""
    os.makedirs(STATE, exist_ok=True)
    if args.local:
        executable = shutil.which(args.local) or args.local
    else:
        executable = download(args.version, this_platform())
    python, interpreter = blender_python(executable)
    if not args.local and python != BLENDER_PYTHONS[args.version]:
        raise SystemExit(f"platform_ci: Blender {args.version} runs Python {python}, the table says "
                         f"{BLENDER_PYTHONS[args.version]}: update BLENDER_PYTHONS")
    if not args.local:  # pytest for the headless tests, in Blender's own Python (CI only: PyPI)
        run([interpreter, "-m", "ensurepip"], check=True)
        run([interpreter, "-m", "pip", "install", "pytest"], check=True)
    json.dump({"executable": executable, "version": args.version, "python": python},
              open(os.path.join(STATE, "blender.json"), "w"), indent=2)
    print(f"platform_ci: Blender {args.version or '(local)'} at {executable}, Python {python}")
    return 0


# --- build and tests ---------------------------------------------------------------------------------

def build_dir(args):
    return os.path.abspath(args.build or os.environ.get("RAYLAB_BUILD_DIR") or os.path.join(ROOT, "build-ci"))


def build(args):
    """The core, the C++ tests and `_raylab` for the Python running this script, which must be the
    recorded Blender's (a module loads only into the Python it was built for)."""
    wanted = saved_blender()["python"]
    running = "%d.%d" % sys.version_info[:2]
    if running != wanted:
        raise SystemExit(f"platform_ci: this is Python {running}, the Blender recorded runs {wanted}: run the "
                         f"build with a Python {wanted}")
    folder = build_dir(args)
    if not os.path.exists(os.path.join(folder, "CMakeCache.txt")):
        configure = ["cmake", "-S", ROOT, "-B", folder, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
                     f"-DPython_EXECUTABLE={sys.executable}"]
        if this_platform() == "windows-x64":
            configure += ["-DCMAKE_C_COMPILER=gcc", "-DCMAKE_CXX_COMPILER=g++"]
        if run(configure).returncode:
            return 1
    return run(["cmake", "--build", folder, "--target", "_raylab", "raylab_tests"]).returncode


def test_cpp(args):
    return run(["ctest", "--output-on-failure", "-j", str(os.cpu_count() or 1)], cwd=build_dir(args)).returncode


def test_python(args):
    return run([sys.executable, "-m", "pytest", "-q", "tests/python", *args.more], cwd=ROOT).returncode


def test_blender(args):
    """tests/blender inside the recorded Blender, headless. Its output is kept: a deprecation warning from
    Blender's API fails the step (tools/deprecations.py finds Blender's among pytest's warnings)."""
    executable = saved_blender()["executable"]
    logs = os.path.join(ROOT, "out", "logs")
    os.makedirs(logs, exist_ok=True)
    log = os.path.join(logs, "blender_tests.log")
    expr = ("import sys, pytest; sys.exit(pytest.main(['-q', '-p', 'no:cacheprovider', '-W', "
            "'always::DeprecationWarning', 'tests/blender']))")
    command = [executable, "-b", "--factory-startup", "--python-exit-code", "1", "--python-expr", expr]
    print("+", " ".join(command[:5]), "... tests/blender", flush=True)
    with open(log, "w") as out:
        process = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                   errors="replace")
        for line in process.stdout:
            sys.stdout.write(line)
            out.write(line)
        rc = process.wait()
    found = run([sys.executable, os.path.join(ROOT, "tools", "deprecations.py"), log]).returncode
    return rc or found


def package(args):
    """The wheel of this Python and the extension: tools/package.py with the further arguments (Linux only),
    the recorded Blender first on PATH when it is one that builds and validates extensions (4.2+)."""
    if not this_platform().startswith("linux"):
        raise SystemExit("platform_ci: packaging is written for Linux only (patchelf and $ORIGIN); Windows and "
                         "macOS wheels need delvewheel's and delocate's steps, not yet written")
    env = dict(os.environ)
    if os.path.exists(os.path.join(STATE, "blender.json")):
        folder = os.path.dirname(os.path.abspath(saved_blender()["executable"]))
        env["PATH"] = folder + os.pathsep + env["PATH"]
    return run([sys.executable, os.path.join(ROOT, "tools", "package.py"), *args.more], env=env).returncode


STEPS = {"deps": deps, "blender": blender, "build": build, "test-cpp": test_cpp, "test-python": test_python,
         "test-blender": test_blender, "package": package}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    steps = parser.add_subparsers(dest="step", required=True)
    steps.add_parser("deps")
    fetch = steps.add_parser("blender")
    fetch.add_argument("version", nargs="?", choices=sorted(BLENDER_PYTHONS))
    fetch.add_argument("--local", metavar="EXE", help="use this Blender instead of downloading one")
    for name in ("build", "test-cpp"):
        steps.add_parser(name).add_argument("--build", help="the build folder (default $RAYLAB_BUILD_DIR or build-ci/)")
    steps.add_parser("test-python", help="any further arguments go to pytest")
    steps.add_parser("test-blender")
    steps.add_parser("package", help="any further arguments go to tools/package.py")
    args, args.more = parser.parse_known_args()
    if args.more and args.step not in ("test-python", "package"):
        parser.error(f"unrecognized arguments: {' '.join(args.more)}")
    if args.step == "blender" and not (args.version or args.local):
        parser.error("blender: give a VERSION to download or --local EXE")
    sys.exit(STEPS[args.step](args))


if __name__ == "__main__":
    main()
