#!/usr/bin/env bash
# A cached Debian root (debootstrap, minbase) to run raylab on another Debian release than the host's.
#
#   tools/debian_root.sh ensure NAME SUITE [PACKAGE...]   make /var/cache/raylab/NAME once (later: seconds)
#   tools/debian_root.sh install NAME PACKAGE...          Debian packages into it, when missing
#   tools/debian_root.sh run NAME COMMAND...              COMMAND inside it, the checkout mounted at /raylab
#
# ensure --arch ARCH NAME SUITE ... makes a root of another architecture (arm64): debootstrap --foreign,
# its second stage run in the root through qemu-user-static and the kernel's binfmt_misc, which also runs
# every later command in it (slowly: emulated).
#
# The roots live under $RAYLAB_ROOTS (default /var/cache/raylab). Making one needs root and Debian's
# package mirror; when either is missing this says so and fails: it never passes silently.
set -euo pipefail
CHECKOUT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ROOTS="${RAYLAB_ROOTS:-/var/cache/raylab}"

die() { echo "debian_root: $*" >&2; exit 1; }

# The host's own mirror (deb.debian.org here): the one address known to be reachable.
mirror() {
  local uri=""
  if [ -f /etc/apt/sources.list.d/debian.sources ]; then
    uri=$(awk '/^URIs:/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources)
  elif [ -f /etc/apt/sources.list ]; then
    uri=$(awk '$1 == "deb" {print $2; exit}' /etc/apt/sources.list)
  fi
  echo "${uri:-http://deb.debian.org/debian}"
}

# qemu-user-static and its binfmt_misc entry for a Debian architecture, so that the host runs its binaries
# (the F flag: the interpreter is opened once, so it works inside a chroot too).
foreign_ready() {  # ARCH
  local qarch
  case "$1" in arm64) qarch=aarch64 ;; *) die "no qemu mapping for architecture $1" ;; esac
  if ! [ -x /usr/bin/qemu-$qarch-static ] || ! command -v update-binfmts >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq qemu-user-static binfmt-support >/dev/null \
      || die "qemu-user-static and binfmt-support could not be installed from Debian's packages"
  fi
  [ -f /proc/sys/fs/binfmt_misc/status ] || mount -t binfmt_misc binfmt_misc /proc/sys/fs/binfmt_misc \
    || die "binfmt_misc cannot be mounted: the host cannot run $1 binaries"
  [ -f /proc/sys/fs/binfmt_misc/qemu-$qarch ] || update-binfmts --enable "qemu-$qarch" >/dev/null \
    || die "update-binfmts could not register qemu-$qarch"
}

in_root() {  # NAME COMMAND... with /proc, /dev, /sys and the checkout mounted, all unmounted after
  local dir="$ROOTS/$1"; shift
  [ -f "$dir/.raylab-arch" ] && foreign_ready "$(cat "$dir/.raylab-arch")"
  mkdir -p "$dir/raylab"
  cp -L /etc/resolv.conf "$dir/etc/resolv.conf" 2>/dev/null || true
  local mounted=()
  # shellcheck disable=SC2317  # called by the trap
  cleanup() { local m; for m in "${mounted[@]}"; do umount -R "$m" 2>/dev/null || umount -lR "$m" 2>/dev/null || true; done; }
  trap cleanup EXIT
  for fs in proc sys dev; do
    mount --rbind "/$fs" "$dir/$fs" && mount --make-rslave "$dir/$fs" && mounted=("$dir/$fs" "${mounted[@]}")
  done
  mount --bind "$CHECKOUT" "$dir/raylab" && mounted=("$dir/raylab" "${mounted[@]}")
  local rc=0
  chroot "$dir" /usr/bin/env -i HOME=/root PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    TERM="${TERM:-dumb}" LANG=C.UTF-8 RAYLAB_IN_ROOT="$(basename "$dir")" "$@" || rc=$?
  cleanup; trap - EXIT
  return $rc
}

ensure() {  # [--arch ARCH] NAME SUITE [PACKAGE...]
  local arch=""
  [ "${1:-}" = "--arch" ] && { arch="$2"; shift 2; }
  local name="$1" suite="$2"; shift 2
  local dir="$ROOTS/$name"
  [ -f "$dir/.raylab-root" ] && return 0
  [ "$(id -u)" -eq 0 ] || die "making the $suite root needs root (debootstrap, chroot, mount)"
  command -v debootstrap >/dev/null || {
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >/dev/null; } \
    || die "debootstrap is missing and could not be installed from Debian's packages"
  mkdir -p "$ROOTS"
  local tmp="$dir.partial"
  rm -rf "$tmp"
  # One debootstrap per suite: its result is kept as a tarball that every later root of the suite unpacks.
  local base="$ROOTS/$suite${arch:+-$arch}-minbase.tar" log="$ROOTS/$suite${arch:+-$arch}.debootstrap.log"
  [ -n "$arch" ] && foreign_ready "$arch"
  if [ ! -f "$base" ]; then
    echo "debian_root: debootstrap $suite ${arch:+$arch }(minbase, from $(mirror)); about 10 minutes the first time${arch:+, more emulated}"
    debootstrap ${arch:+--arch "$arch" --foreign} --variant=minbase "$suite" "$tmp" "$(mirror)" > "$log" 2>&1 \
      || die "debootstrap $suite failed (is $(mirror) reachable?); see $log"
    if [ -n "$arch" ]; then
      chroot "$tmp" /debootstrap/debootstrap --second-stage >> "$log" 2>&1 \
        || die "debootstrap's second stage ($arch, emulated) failed; see $log"
    fi
    tar -C "$tmp" -cf "$base.partial" . && mv "$base.partial" "$base"
  else
    mkdir -p "$tmp" && tar -C "$tmp" -xf "$base"
  fi
  # The mirror may be a frozen snapshot: apt must take its Release files after their Valid-Until date
  # (sid's are valid for a week only).
  echo 'Acquire::Check-Valid-Until "false";' > "$tmp/etc/apt/apt.conf.d/99raylab-snapshot"
  [ -n "$arch" ] && echo "$arch" > "$tmp/.raylab-arch"
  mv "$tmp" "$dir"
  if [ $# -gt 0 ]; then
    in_root "$name" sh -c "apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $* >/dev/null" \
      || { rm -rf "$dir"; die "installing $* in the $suite root failed"; }
  fi
  echo "$suite $*" > "$dir/.raylab-root"
}

cmd="${1:-}"; shift || true
case "$cmd" in
  ensure) ensure "$@" ;;
  install) name="$1"; shift; [ -f "$ROOTS/$name/.raylab-root" ] || die "no root $name: run ensure first"
    in_root "$name" sh -c 'for p in "$@"; do dpkg-query -W -f="\${Status}" "$p" 2>/dev/null | grep -q "install ok installed" || exec sh -c "apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $* >/dev/null"; done' sh "$@" ;;
  run) name="$1"; shift; [ -f "$ROOTS/$name/.raylab-root" ] || die "no root $name: run ensure first"; in_root "$name" "$@" ;;
  *) echo "usage: tools/debian_root.sh ensure [--arch ARCH] NAME SUITE [PACKAGE...] | install NAME PACKAGE... | run NAME COMMAND..."; exit 2 ;;
esac
