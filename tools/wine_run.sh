#!/usr/bin/env bash
# Runs a Windows program under wine64 with raylab's cached prefix, the DLLs it needs (TBB from
# RAYLAB_WINDOWS_DEPS, the mingw runtime) found through WINEPATH. The prefix is made on first use
# (wineboot, about ten seconds). The Windows build's ctest runs its tests through this script.
#
#   RAYLAB_WINDOWS_DEPS=... tools/wine_run.sh build-windows/raylab_tests.exe --gtest_brief=1
set -euo pipefail
ROOTS="${RAYLAB_ROOTS:-/var/cache/raylab}"
export WINEPREFIX="${WINEPREFIX:-$ROOTS/wine64}" WINEDEBUG="${WINEDEBUG:--all}" WINEARCH=win64
# No desktop, no Mono or Gecko installers: the tests are console programs.
export WINEDLLOVERRIDES="${WINEDLLOVERRIDES:-mscoree,mshtml=;winemenubuilder.exe=d}" DISPLAY=
deps="${RAYLAB_WINDOWS_DEPS:?the folder of the Windows TBB (tools/cross_windows.sh makes it)}"
runtime=$(dirname "$(x86_64-w64-mingw32-g++-posix -print-file-name=libstdc++-6.dll)")
winpath=""
for d in "$deps/bin" "$runtime" /usr/x86_64-w64-mingw32/lib; do winpath+="Z:${d//\//\\};"; done
export WINEPATH="$winpath${WINEPATH:-}"
if [ ! -f "$WINEPREFIX/system.reg" ]; then
  mkdir -p "$WINEPREFIX"
  wineboot --init >/dev/null 2>&1 || true
  wineserver -w
fi
# Not exec: a program wine fails to start may print nothing (WINEDEBUG=-all hides wine's own errors),
# so its exit status is said here.
status=0
wine "$@" || status=$?
[ $status -eq 0 ] || echo "wine_run: wine $1 exited with status $status" >&2
exit $status
