"""The lists of structure kinds in the project's prose, made from the core's table (raylab.STRUCTURE_INFO)
so that a new kind cannot leave a sentence behind. In Markdown a list stands between markers:

    <!--kinds:all-->none, aabb, octree, bvh, grid<!--/kinds-->     every kind, in the Structure menu's order
    <!--kinds:boxes-->aabb, octree, bvh, grid<!--/kinds-->         the kinds with boxes to draw

    /usr/bin/python3 tools/kind_lists.py            lists the stale ones (exit 1 if any)
    /usr/bin/python3 tools/kind_lists.py --write    writes them anew

The add-on's one-line description (bl_info, literal: Blender reads it without running the add-on) is
checked too: it names every kind with boxes by its label.
"""
import argparse
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "addon"))

import raylab  # noqa: E402

MARKED = re.compile(r"<!--kinds:(\w+)-->(.*?)<!--/kinds-->", re.S)
FORMS = {
    "all": lambda info: True,
    "boxes": lambda info: info["has_boxes"],
}


def kinds(form):
    return ", ".join(name for name, info in raylab.STRUCTURE_INFO.items() if FORMS[form](info))


def prose_files():
    files = [ROOT / "README.md", ROOT / "ARCHITECTURE.md", *sorted((ROOT / "levels").glob("*/text.md")),
             *sorted((ROOT / "docs").rglob("*.md"))]
    return [path for path in files if path.is_file()]


def rewritten(text):
    return MARKED.sub(lambda m: f"<!--kinds:{m.group(1)}-->{kinds(m.group(1))}<!--/kinds-->", text)


def description_labels():
    """The labels of the kinds with boxes, as the add-on's description names them."""
    return [info["label"] for info in raylab.STRUCTURE_INFO.values() if info["has_boxes"]]


def stale():
    """[(path, what is stale)] across the prose and the add-on's description."""
    found = []
    for path in prose_files():
        text = path.read_text(encoding="utf-8")
        for match in MARKED.finditer(text):
            if match.group(1) not in FORMS:
                found.append((path, f"unknown list form {match.group(1)!r} (known: {', '.join(FORMS)})"))
            elif match.group(2) != kinds(match.group(1)):
                found.append((path, f"{match.group(2)!r} should be {kinds(match.group(1))!r}"))
    init = (ROOT / "addon" / "raylab" / "__init__.py").read_text(encoding="utf-8")
    description = re.search(r'"description": "([^"]*)"', init).group(1)
    missing = [label for label in description_labels() if label.lower() not in description.lower()]
    if missing:
        found.append((ROOT / "addon" / "raylab" / "__init__.py", f"bl_info's description lacks {missing}"))
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--write", action="store_true", help="write the marked lists anew")
    args = parser.parse_args()
    if args.write:
        for path in prose_files():
            text = path.read_text(encoding="utf-8")
            if rewritten(text) != text:
                path.write_text(rewritten(text), encoding="utf-8")
                print(f"wrote {path.relative_to(ROOT)}")
    problems = stale()
    for path, what in problems:
        print(f"{path.relative_to(ROOT)}: {what}")
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
