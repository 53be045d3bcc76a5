#!/usr/bin/env bash
# Debian's source package of the host's release, unpacked into a folder, through a private apt state with
# the deb-src line of the host's own mirror (the system's lists stay as they are). Prints the source folder.
#
#   tools/debian_source.sh onetbb=2021.8.0-2+deb12u1 /tmp/work   ->  /tmp/work/onetbb-2021.8.0
set -euo pipefail
die() { echo "debian_source: $*" >&2; exit 1; }
[ $# -eq 2 ] || die "usage: debian_source.sh PACKAGE[=VERSION] FOLDER"
spec=$1 work=$2
command -v dpkg-source >/dev/null || DEBIAN_FRONTEND=noninteractive apt-get install -y -qq dpkg-dev >/dev/null \
  || die "dpkg-dev could not be installed"
uri=$(awk '/^URIs:/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources 2>/dev/null || true)
codename=$(. /etc/os-release && echo "$VERSION_CODENAME")
mkdir -p "$work/apt/lists/partial"
printf 'deb-src %s %s main\ndeb-src %s %s-updates main\n' "${uri:-http://deb.debian.org/debian}" "$codename" \
  "${uri:-http://deb.debian.org/debian}" "$codename" > "$work/apt/sources.list"
apt_private=(-o "Dir::Etc::SourceList=$work/apt/sources.list" -o "Dir::Etc::SourceParts=-"
  -o "Dir::State::Lists=$work/apt/lists" -o "APT::Sandbox::User=root")
apt-get "${apt_private[@]}" update -qq >/dev/null || die "apt-get update of the source lists failed"
(cd "$work" && apt-get "${apt_private[@]}" source -qq "$spec" >/dev/null) || die "apt-get source $spec failed"
src=$(find "$work" -mindepth 1 -maxdepth 1 -type d -name "${spec%%=*}-*" | head -1)
[ -n "$src" ] || die "no ${spec%%=*} source folder after apt-get source"
echo "$src"
