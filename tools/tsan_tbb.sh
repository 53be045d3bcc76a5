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
  command -v dpkg-source >/dev/null || DEBIAN_FRONTEND=noninteractive apt-get install -y -qq dpkg-dev >/dev/null \
    || die "dpkg-dev could not be installed"
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
  # A private apt state with the deb-src line of the host's own mirror: the system's lists stay as they are.
  uri=$(awk '/^URIs:/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources 2>/dev/null || true)
  codename=$(. /etc/os-release && echo "$VERSION_CODENAME")
  mkdir -p "$work/lists/partial"
  printf 'deb-src %s %s main\ndeb-src %s %s-updates main\n' "${uri:-http://deb.debian.org/debian}" "$codename" \
    "${uri:-http://deb.debian.org/debian}" "$codename" > "$work/sources.list"
  apt_private=(-o "Dir::Etc::SourceList=$work/sources.list" -o "Dir::Etc::SourceParts=-" -o "Dir::State::Lists=$work/lists"
    -o "APT::Sandbox::User=root")
  echo "tsan_tbb: oneTBB $version from Debian's source package, built with -fsanitize=thread (a few minutes, once)" >&2
  apt-get "${apt_private[@]}" update -qq >/dev/null || die "apt-get update of the source lists failed"
  (cd "$work" && apt-get "${apt_private[@]}" source -qq "onetbb=$version" >/dev/null) || die "apt-get source onetbb=$version failed"
  src=$(find "$work" -mindepth 1 -maxdepth 1 -type d -name "onetbb-*" | head -1)
  [ -n "$src" ] || die "no onetbb source folder after apt-get source"
  # TBB_STRICT off: GCC warns that TSan does not model atomic_thread_fence, and strict makes it an error.
  cmake -S "$src" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTBB_TEST=OFF -DTBB_STRICT=OFF \
    -DTBB_SANITIZE=thread -DTBBMALLOC_BUILD=OFF -DTBB_EXAMPLES=OFF -DCMAKE_INSTALL_PREFIX="$dir.partial" >/dev/null
  cmake --build "$work/build" -- -j"$(nproc)" >/dev/null || die "building oneTBB with TSan failed"
  rm -rf "$dir.partial" && cmake --install "$work/build" >/dev/null && rm -rf "$dir" && mv "$dir.partial" "$dir"
fi
echo "$dir/lib"
