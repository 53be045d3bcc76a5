#!/usr/bin/env bash
# The core and its C++ tests for Windows x64, cross-compiled with Debian's mingw-w64 and run under wine64;
# then the Python module (.pyd) for CPython 3.11 on Windows, built but not run (no Windows Python here).
#
#   tools/cross_windows.sh [--no-tests] [--no-compare] [--no-module]      (./raylab test --windows runs it)
#
# --no-compare skips the bit-for-bit comparison with the host's hits (tools/same_hits.sh).
#
# Made once and cached in $RAYLAB_ROOTS (/var/cache/raylab): oneTBB built from Debian's own source
# package with this toolchain, GoogleTest from Debian's /usr/src/googletest, the wine prefix, CPython's
# Windows headers (Debian's python3.11 source: Include/ and PC/pyconfig.h). GLM and nlohmann-json are
# the host's headers (header-only). No OpenImageIO: the Windows build has RAYLAB_IMAGE_IO off (no C++
# test uses it).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ROOTS="${RAYLAB_ROOTS:-/var/cache/raylab}"
BUILD="${RAYLAB_WINDOWS_BUILD_DIR:-$ROOT/build-windows}"
TOOLCHAIN="$ROOT/tools/cmake/windows-x64-mingw.cmake"
CXX=x86_64-w64-mingw32-g++-posix
die() { echo "cross_windows: $*" >&2; exit 1; }
# What the script leaves behind however it ends: a download's work folder, the wineserver it started.
work="" wine_server=0
cleanup() { [ -z "$work" ] || rm -rf "$work"; [ $wine_server -eq 0 ] || wineserver -k 2>/dev/null || true; }
trap cleanup EXIT
tests=1 compare=1 module=1
for a in "$@"; do
  case $a in
    --no-tests) tests=0 ;;
    --no-compare) compare=0 ;;
    --no-module) module=0 ;;
    *) die "unknown argument $a" ;;
  esac
done
command -v $CXX >/dev/null || die "needs g++-mingw-w64-x86-64-posix (./raylab test --windows installs it)"
command -v wine >/dev/null || die "needs wine64 and wine (./raylab test --windows installs them)"

tbb_version=$(dpkg-query -W -f='${source:Version}' libtbb-dev 2>/dev/null) || die "libtbb-dev is not installed"
DEPS="$ROOTS/windows-x64-deps-tbb$tbb_version"
export RAYLAB_WINDOWS_DEPS="$DEPS"
mkdir -p "$ROOTS"

# A CMake project configured, built and installed into $DEPS with the Windows toolchain.
cross_install() {  # SOURCE BUILD [cmake arguments...]
  local src=$1 build=$2
  shift 2
  cmake -S "$src" -B "$build" -G Ninja -DCMAKE_TOOLCHAIN_FILE="$TOOLCHAIN" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_INSTALL_PREFIX="$DEPS.partial" "$@" >/dev/null
  cmake --build "$build" -- -j"$(nproc)" >/dev/null
  cmake --install "$build" >/dev/null
}

if [ ! -f "$DEPS/bin/libtbb12.dll" ]; then
  echo "cross_windows: oneTBB $tbb_version and GoogleTest for mingw-w64 (a few minutes, once)" >&2
  work=$(mktemp -d)
  rm -rf "$DEPS.partial"
  src=$("$ROOT/tools/debian_source.sh" "onetbb=$tbb_version" "$work")
  # TBB_STRICT off: mingw's GCC warns in TBB's sources, and strict makes warnings errors. A DLL (TBB
  # does not support being linked statically), copied beside the programs or found through WINEPATH.
  cross_install "$src" "$work/tbb" -DTBB_TEST=OFF -DTBB_STRICT=OFF -DTBBMALLOC_BUILD=OFF -DTBB_EXAMPLES=OFF
  cross_install /usr/src/googletest "$work/gtest" -DBUILD_GMOCK=OFF
  # The header-only libraries: the host's headers under a folder of their own (the host's /usr/include
  # on the include path would shadow the Windows C library's headers), with the config files CMake finds.
  mkdir -p "$DEPS.partial/include" "$DEPS.partial/lib/cmake/glm" "$DEPS.partial/lib/cmake/nlohmann_json"
  ln -s /usr/include/glm "$DEPS.partial/include/glm"
  ln -s /usr/include/nlohmann "$DEPS.partial/include/nlohmann"
  for package in glm:glm::glm nlohmann_json:nlohmann_json::nlohmann_json; do
    name=${package%%:*} target=${package#*:}
    cat >"$DEPS.partial/lib/cmake/$name/${name}Config.cmake" <<EOF
# Made by tools/cross_windows.sh: the host's headers, linked into this folder's include/.
if(NOT TARGET $target)
  add_library($target INTERFACE IMPORTED)
  set_target_properties($target PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "$DEPS/include")
endif()
EOF
  done
  json_version=$(dpkg-query -W -f='${Version}' nlohmann-json3-dev | cut -d- -f1)
  cat >"$DEPS.partial/lib/cmake/nlohmann_json/nlohmann_jsonConfigVersion.cmake" <<EOF
set(PACKAGE_VERSION $json_version)
if(PACKAGE_FIND_VERSION VERSION_GREATER PACKAGE_VERSION)
  set(PACKAGE_VERSION_COMPATIBLE FALSE)
else()
  set(PACKAGE_VERSION_COMPATIBLE TRUE)
endif()
EOF
  rm -rf "$DEPS" && mv "$DEPS.partial" "$DEPS"
  rm -rf "$work" && work=""
fi

start=$SECONDS
if [ ! -f "$BUILD/build.ninja" ]; then
  cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_TOOLCHAIN_FILE="$TOOLCHAIN" -DCMAKE_BUILD_TYPE=Release \
    -DRAYLAB_WINDOWS_DEPS="$DEPS" -DRAYLAB_PYTHON=OFF -DRAYLAB_IMAGE_IO=OFF >/dev/null
fi
cmake --build "$BUILD" -- -j"$(nproc)" | { grep -v "^\[" || true; }
echo "cross_windows: core and tests built in $((SECONDS - start)) s"

if [ $tests -eq 1 ]; then
  start=$SECONDS
  grep -q -m1 avx2 /proc/cpuinfo && echo "cross_windows: this CPU has AVX2: the AVX2 paths run under wine"
  # One wineserver for the whole run, started before any test and stopped when this script ends. Each
  # wine otherwise starts its own server, which leaves the moment its program ends (persistence 0); a
  # test started while one was shutting down failed with "a wine server seems to be running, but I
  # cannot connect to it". `wineserver -p` does nothing while another server runs, so wait for that one.
  # Then one program starts the prefix's services (services.exe, winedevice.exe...), which live as long
  # as the server: with their output to /dev/null, not to the first test's pipe, which ctest would wait
  # on for ever.
  "$ROOT/tools/wine_run.sh" cmd /c exit 0 </dev/null >/dev/null 2>&1  # makes the prefix on first use
  export WINEPREFIX="${WINEPREFIX:-$ROOTS/wine64}"
  wineserver -w
  wineserver -p || die "could not start a persistent wineserver"
  wine_server=1
  "$ROOT/tools/wine_run.sh" cmd /c exit 0 </dev/null >/dev/null 2>&1
  # A test wine fails to start is run once more (--repeat until-pass:2): CI met one that failed in
  # 0.01 s with no output at all, before gtest printed a line, and it did not recur. Both attempts show
  # in the log, and a test that fails twice fails the run. The same tests run on Linux (host, roots,
  # sanitizers) with no second attempt.
  (cd "$BUILD" && ctest --output-on-failure --repeat until-pass:2 -j"$(nproc)")
  echo "cross_windows: C++ tests under wine in $((SECONDS - start)) s"
fi

if [ $compare -eq 1 ]; then
  "$ROOT/tools/same_hits.sh" "Windows x64" "$ROOT/tools/wine_run.sh" "$BUILD/raylab_hit_dump.exe"
fi

# The module for CPython 3.11 on Windows (the official Blender 4.2-5.0's Python): a module-only build
# (RAYLAB_WHEEL_INCLUDE) against CPython's Windows headers and the host's pybind11, linked against an
# import library of python311.dll made from the symbols the module's objects import (a .def file and
# dlltool: no Windows Python here to take python311.lib from). It lands in $PYBUILD/module with the DLLs
# it needs beside it (the way a Windows wheel ships them). It cannot be loaded here.
if [ $module -eq 1 ]; then
  start=$SECONDS
  headers="$DEPS/cpython-windows"
  if [ ! -f "$headers/python3.11/pyconfig.h" ]; then
    work=$(mktemp -d)
    src=$("$ROOT/tools/debian_source.sh" python3.11 "$work")
    rm -rf "$headers.partial" && mkdir -p "$headers.partial/python3.11"
    cp -r "$src/Include/." "$src/PC/pyconfig.h" "$headers.partial/python3.11/"
    ln -s /usr/include/pybind11 "$headers.partial/pybind11"
    rm -rf "$headers" && mv "$headers.partial" "$headers"
    rm -rf "$work" && work=""
  fi
  PYBUILD="$BUILD-python"
  implib="$PYBUILD/libpython311.dll.a"
  if [ ! -f "$PYBUILD/build.ninja" ]; then
    cmake -S "$ROOT" -B "$PYBUILD" -G Ninja -DCMAKE_TOOLCHAIN_FILE="$TOOLCHAIN" -DCMAKE_BUILD_TYPE=Release \
      -DRAYLAB_WINDOWS_DEPS="$DEPS" -DRAYLAB_WHEEL_INCLUDE="$headers" -DRAYLAB_WHEEL_SUFFIX=.cp311-win_amd64.pyd \
      -DRAYLAB_WHEEL_LIBRARY="$implib" -DRAYLAB_MODULE_DIR="$PYBUILD/module" >/dev/null
  fi
  objects=$(ninja -C "$PYBUILD" -t targets all | grep -o '^CMakeFiles/_raylab\.dir/[^:]*\.obj')
  ninja -C "$PYBUILD" $objects | { grep -v "^\[" || true; }
  { echo "LIBRARY python311.dll"; echo "EXPORTS"
    (cd "$PYBUILD" && x86_64-w64-mingw32-nm -u $objects) | sed -n 's/^ *U \(__imp_\)\{0,1\}\(_\{0,1\}Py[A-Za-z0-9_]*\)$/\2/p' | sort -u
  } > "$PYBUILD/python311.def"
  x86_64-w64-mingw32-dlltool -d "$PYBUILD/python311.def" -D python311.dll -l "$implib"
  cmake --build "$PYBUILD" --target _raylab | { grep -v "^\[" || true; }
    pyd="$PYBUILD/module/_raylab.cp311-win_amd64.pyd"
  # Beside it, every DLL it imports that is not Windows' or Python's own (TBB, the mingw runtime).
  runtime=$(dirname "$($CXX -print-file-name=libstdc++-6.dll)")
  for dll in $(x86_64-w64-mingw32-objdump -p "$pyd" "$DEPS/bin/libtbb12.dll" | sed -n 's/^\s*DLL Name: //p' | sort -u); do
    for d in "$DEPS/bin" "$runtime" /usr/x86_64-w64-mingw32/lib; do
      # Stripped: Debian's libstdc++-6.dll keeps its symbols (24 MB).
      [ -f "$d/$dll" ] && x86_64-w64-mingw32-strip --strip-unneeded -o "$PYBUILD/module/$dll" "$d/$dll" && break
    done
  done
  echo "cross_windows: $pyd ($(grep -c . "$PYBUILD/python311.def") lines of python311.def) in $((SECONDS - start)) s;" \
    "it imports: $(x86_64-w64-mingw32-objdump -p "$pyd" | sed -n 's/^\s*DLL Name: //p' | tr '\n' ' ')"
  echo "cross_windows: beside it: $(cd "$PYBUILD/module" && ls ./*.dll | tr '\n' ' ')"
fi
