"""Fails when Blender's output (a log of the headless Blender suite) holds a deprecation warning of
Blender's API: Blender's own words for them ("'Material.use_nodes' is expected to be removed in Blender
6.0"), or a DeprecationWarning raised from a line of raylab's add-on. Prints each one with where it came from.

    /usr/bin/python3 tools/deprecations.py out/logs/blender_tests.log
"""
import re
import sys

BLENDER_WORDS = re.compile(r"DeprecationWarning: .*(expected to be removed in Blender|is deprecated)")
FROM_RAYLAB = re.compile(r"(raylab/|tests/blender/)\S*:\d+: DeprecationWarning")


def deprecations(text):
    """The distinct deprecation lines of `text` that come from Blender's API or from raylab's code."""
    found = []
    for line in text.splitlines():
        line = line.strip()
        if (BLENDER_WORDS.search(line) or FROM_RAYLAB.search(line)) and line not in found:
            found.append(line)
    return found


def main():
    found = deprecations(open(sys.argv[1], errors="replace").read())
    for line in found:
        print(f"deprecation: {line}")
    if found:
        print(f"deprecations: {len(found)} distinct deprecation warnings in {sys.argv[1]}")
        return 1
    print(f"deprecations: none in {sys.argv[1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
