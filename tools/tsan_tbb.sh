#!/usr/bin/env bash
# oneTBB built with ThreadSanitizer, from Debian's own source package of the installed libtbb-dev, so
# that TSan sees TBB's synchronisation (the packaged library is not instrumented: every parallel loop
# would be reported as a race). Made once and cached; prints the folder that holds libtbb.so.12.
#
#   tools/tsan_tbb.sh     ->  /var/cache/raylab/tbb-tsan-<version>/lib
set -euo pipefail
ROOTS="${RAYLAB_ROOTS:-/var/cache/raylab}"
die() { echo "tsan_tbb: $*" >&2; exit 1; }

version=$(dpkg-query -W -f='${source:Version}' libtbb-dev 2>/dev/null) || die "libtbb-dev is not installed"
dir="$ROOTS/tbb-tsan-$version"
if [ ! -f "$dir/lib/libtbb.so.12" ]; then
  [ "$(id -u)" -eq 0 ] || die "making $dir needs root (Debian's dpkg-dev, the cache folder)"
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
  echo "tsan_tbb: oneTBB $version from Debian's source package, built with -fsanitize=thread (a few minutes, once)" >&2
  src=$("$(dirname "${BASH_SOURCE[0]}")/debian_source.sh" "onetbb=$version" "$work")
  # TBB_STRICT off: GCC warns that TSan does not model atomic_thread_fence, and strict makes it an error.
  cmake -S "$src" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTBB_TEST=OFF -DTBB_STRICT=OFF \
    -DTBB_SANITIZE=thread -DTBBMALLOC_BUILD=OFF -DTBB_EXAMPLES=OFF -DCMAKE_INSTALL_PREFIX="$dir.partial" >/dev/null
  cmake --build "$work/build" -- -j"$(nproc)" >/dev/null || die "building oneTBB with TSan failed"
  rm -rf "$dir.partial" && cmake --install "$work/build" >/dev/null && rm -rf "$dir" && mv "$dir.partial" "$dir"
fi
echo "$dir/lib"
