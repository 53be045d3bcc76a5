"""Compares the exact counts of two `./raylab demo` runs (results.json), e.g. Debian 12 against Debian 13.

    /usr/bin/python3 tools/compare_demo.py out/demo/results.json out/demo-debian13/results.json

Times differ from run to run; the counts (triangles, rays of each kind, rays ignored, box and triangle
tests, nodes visited) are exact and must be equal. Prints each difference; exits 1 when there is one.
"""
import json
import sys

COUNTS = ("rays", "rays_primary", "rays_shadow", "rays_reflection", "rays_refraction", "rays_ignored",
          "box_tests", "triangle_tests", "nodes_visited")


def differences(a, b):
    found = []
    for key in ("width", "height", "triangles"):
        if a[key] != b[key]:
            found.append(f"{key}: {a[key]} against {b[key]}")
    for ss in sorted(set(a["measurements"]) | set(b["measurements"])):
        ma, mb = a["measurements"].get(ss, {}), b["measurements"].get(ss, {})
        for structure in sorted(set(ma) | set(mb)):
            sa, sb = ma.get(structure, {}), mb.get(structure, {})
            for key in COUNTS:
                if sa.get(key) != sb.get(key):
                    found.append(f"super sampling {ss}, {structure}, {key}: {sa.get(key)} against {sb.get(key)}")
    return found


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    a, b = (json.load(open(path)) for path in sys.argv[1:])
    found = differences(a, b)
    for line in found:
        print(f"compare_demo: {line}")
    if found:
        sys.exit(1)
    print(f"compare_demo: the same counts ({a['triangles']:,} triangles, {len(a['measurements'])} super samplings, "
          f"{len(COUNTS)} counts per structure)")


if __name__ == "__main__":
    main()
