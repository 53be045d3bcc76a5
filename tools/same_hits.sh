#!/usr/bin/env bash
# The same hits on another platform, bit for bit: raylab_hit_dump (tests/native/dump) built for the host
# and for the other platform writes every structure's answers (every kind, contract and builder; single
# rays, batches and counted batches) for the same rays, and the two files must be equal.
#
#   tools/same_hits.sh LABEL COMMAND...      COMMAND runs the other platform's raylab_hit_dump
#   tools/same_hits.sh "Windows x64" tools/wine_run.sh build-windows/raylab_hit_dump.exe
#   QEMU_LD_PREFIX=ROOT tools/same_hits.sh "Linux arm64" build-arm64/raylab_hit_dump
#
# The host's program is built in $RAYLAB_BUILD_DIR (build/).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
label=${1:?usage: tools/same_hits.sh LABEL COMMAND...}
shift
[ $# -gt 0 ] || { echo "same_hits: no command for $label" >&2; exit 2; }
host_build="${RAYLAB_BUILD_DIR:-$ROOT/build}"
[ -f "$host_build/build.ninja" ] || { echo "same_hits: no host build in $host_build (./raylab setup makes it)" >&2; exit 1; }
start=$SECONDS
cmake --build "$host_build" --target raylab_hit_dump | { grep -v "^\[" || true; }
dump=$(mktemp -d)
trap 'rm -rf "$dump"' EXIT
"$host_build/raylab_hit_dump" "$dump/host-rays" "$dump/host-hits"
"$@" "$dump/other-rays" "$dump/other-hits" || { echo "same_hits: $label's raylab_hit_dump failed" >&2; exit 1; }
same=1
cmp "$dump/host-rays" "$dump/other-rays" || same=0
cmp "$dump/host-hits" "$dump/other-hits" || same=0
[ $same -eq 1 ] || { echo "same_hits: the host and $label differ (above: the rays, or the hits)" >&2; exit 1; }
echo "same_hits: the host's and $label's hits equal bit for bit, $(stat -c %s "$dump/host-hits") bytes ($((SECONDS - start)) s)"
