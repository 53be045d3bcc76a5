#!/usr/bin/env bash
# The bare-machine check: the packaged wheel of the root's Python (out/wheels/, ./raylab package), unpacked
# into a folder on sys.path as pip and Blender do, in a root that has python3 and numpy but none of
# raylab's build dependencies (no TBB, no OpenImageIO, no compiler), must import, trace
# rays, and resolve every library either to its own bundle or to the base system.
#
#   tools/bare_check.sh [--ensure] ROOT_NAME SUITE    (--ensure: only make the root)
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
only_ensure=0
[ "${1:-}" = "--ensure" ] && { only_ensure=1; shift; }
name="$1" suite="$2"
WHEELS="$(dirname "$HERE")/out/wheels"
ROOTS="${RAYLAB_ROOTS:-/var/cache/raylab}"

"$HERE/debian_root.sh" ensure "$name" "$suite" python3 python3-numpy
[ $only_ensure -eq 1 ] && exit 0
dir="$ROOTS/$name"
tag=$(chroot "$dir" /usr/bin/python3 -c "import sys; print('cp%d%d' % sys.version_info[:2])")
wheel=$(ls "$WHEELS"/raylab_core-*-"$tag"-"$tag"-*.whl 2>/dev/null | head -1)
[ -n "$wheel" ] || { echo "bare check: no wheel for $tag in $WHEELS (./raylab package --all-pythons)"; exit 1; }
rm -rf "$dir/opt/raylab-bare" && mkdir -p "$dir/opt/raylab-bare"
python3 -c "import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extractall(sys.argv[2])" "$wheel" "$dir/opt/raylab-bare"
"$HERE/debian_root.sh" run "$name" /usr/bin/python3 - <<'EOF'
import glob, re, subprocess, sys, sysconfig
sys.path.insert(0, "/opt/raylab-bare")
for dev in ("pkg-config", "g++", "cmake"):
    assert subprocess.run(["sh", "-c", f"command -v {dev}"], capture_output=True).returncode != 0, f"{dev} is installed: not bare"
module = glob.glob("/opt/raylab-bare/raylab_core/_raylab" + sysconfig.get_config_var("EXT_SUFFIX"))
assert module, f"the wheel has no module for Python {sys.version_info[:2]}"
ldd = subprocess.run(["ldd", module[0]], capture_output=True, text=True, check=True).stdout
print(f"ldd {module[0]}:\n{ldd}")
for line in ldd.splitlines():
    match = re.match(r"\s*(\S+) => (\S+)", line)
    if not match:
        continue
    soname, target = match.groups()
    assert target != "not found", f"{soname} not found"
    in_bundle = target.startswith("/opt/raylab-bare/raylab_core/libs/")
    in_base = re.match(r"(libc|libm|libstdc\+\+|libgcc_s|libpthread|libdl|librt)\.so", soname)
    assert in_bundle or in_base, f"{soname} resolves to {target}: neither the bundle nor the base system"
import numpy as np
import raylab
vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
triangles = np.array([[0, 1, 2]], np.uint32)
for structure in raylab.STRUCTURES:
    hits = raylab.build(vertices, triangles, structure=structure).intersect(
        np.array([[0.2, 0.2, 1.0]], np.float32), np.array([[0, 0, -1]], np.float32))
    assert hits.hit[0] and abs(hits.t[0] - 1.0) < 1e-6, (structure, hits.t)
assert raylab.native.core.__file__.startswith("/opt/raylab-bare/raylab_core/"), raylab.native.core.__file__
print(f"bare check: raylab from its wheel imports and traces with Python {sys.version.split()[0]} "
      f"(NumPy {np.__version__}) on {open('/etc/debian_version').read().strip()}")
EOF
