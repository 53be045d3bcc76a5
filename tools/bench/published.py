"""The charts of the published benchmark, redrawn from its report (docs/bench/results.md) without
measuring anything: the report's tables read back into the parts of results.json the charts draw.

    /usr/bin/python3 -m tools.bench.published       (from the checkout)

A full run's results.json is not kept in the checkout; its report is, with every number a chart shows
(rates as the report rounds them: three digits). The charts go where ./raylab bench --publish puts them.
"""
import re

from . import ROOT, log
from .charts import write_charts
from .report import PUBLISHED

REPORT = ROOT / "docs" / "bench" / "results.md"
RATE = re.compile(r"^([\d.]+) ([kM])$")


def tables(text):
    """Every Markdown table of the report: (the line of text above it, its header, its rows of cells)."""
    found, lines = [], text.splitlines()
    i = 0
    while i < len(lines):
        if lines[i].startswith("|") and i + 1 < len(lines) and lines[i + 1].startswith("|---"):
            caption = next((lines[k] for k in range(i - 1, -1, -1) if lines[k].strip()), "")
            header = cells(lines[i])
            rows = []
            i += 2
            while i < len(lines) and lines[i].startswith("|"):
                rows.append(cells(lines[i]))
                i += 1
            found.append((caption, header, rows))
        else:
            i += 1
    return found


def cells(line):
    return [c.strip() for c in line.strip().strip("|").split("|")]


def table(found, first_header, caption=None):
    """The rows of the first table whose header starts with `first_header` (and whose caption line
    starts with `caption`), as dicts by column name (a repeated name gets its column's index)."""
    for above, header, rows in found:
        if header[:len(first_header)] == first_header and (caption is None or above.startswith(caption)):
            names = [h if header.index(h) == i else f"{h}#{i}" for i, h in enumerate(header)]
            return [dict(zip(names, row)) for row in rows]
    raise ValueError(f"the report has no table {first_header}")


def rate(cell):
    """A rate as the report prints it ("12.6 k", "1.23 M") in rays per second; None for "-"."""
    match = RATE.match(cell)
    if not match:
        return None
    return float(match[1]) * (1e3 if match[2] == "k" else 1e6)


def number(cell):
    return float(cell.replace(",", "").split(" ")[0])


def results_from_report(text):
    """The report's numbers in the shape of results.json, as far as the charts read it."""
    found = tables(text)
    embree = re.search(r"Embree ([\d.]+)", text)[1]
    results = {"configuration": "full", "machine": {"embree": embree}, "meshes": {}, "blender": {"meshes": {}}}
    for row in table(found, ["mesh", "tris", "tracer"]):
        mesh = results["meshes"].setdefault(row["mesh"], {"triangles": int(number(row["tris"])), "tracers": []})
        camera, random = rate(row["2t"]), rate(row["2t#9"])
        if row["tracer"].startswith("Blender"):
            results["blender"]["meshes"][row["mesh"]] = {"ray_sets": {
                "camera": {"rays_per_second": rate(row["camera closest 1t"])},
                "random": {"rays_per_second": rate(row["random closest 1t"])}}}
            continue
        runs = [{"rays": rays, "query": "closest", "threads": 2, "rays_per_second": value}
                for rays, value in (("camera", camera), ("random", random))]
        mesh["tracers"].append({"name": row["tracer"], "kind": "embree" if row["tracer"].startswith("embree")
                                else "raylab", "error": None, "tracing": {"runs": runs}})
    for row in table(found, ["mesh", "threads"]):
        if row["threads"] != "2":
            continue
        bvh = next(t for t in results["meshes"][row["mesh"]]["tracers"] if t["name"] == "bvh")
        ours, theirs = (float(x) for x in row["bytes/tri BVH / Embree"].split("/"))
        bvh["ratios_to_embree_medium"] = {
            "camera_closest_2t_rays_per_second": float(row["BVH/Embree camera closest"]),
            "camera_any_2t_rays_per_second": float(row["camera any"]),
            "random_closest_2t_rays_per_second": float(row["random closest"]),
            "random_any_2t_rays_per_second": float(row["random any"]),
            "build_2t_seconds": float(row["build"]), "memory_bytes": ours / theirs}
    # The price of exactness: one-thread speeds as ratios to Embree medium (its own row says 1.00), which is
    # all the chart reads of them, and the wrong answers per million on the hostile rays.
    for row in table(found, ["mesh", "tracer", "camera closest"]) if "## The price of exactness" in text else []:
        tracer = next(t for t in results["meshes"][row["mesh"]]["tracers"] if t["name"] == row["tracer"])
        for ray_set in ("camera", "random"):
            tracer["tracing"]["runs"].append({"rays": ray_set, "query": "closest", "threads": 1,
                                              "rays_per_second": float(row[f"{ray_set} closest"])})
        tracer["exactness"] = {"hostile": {"wrong_per_million": number(row["hostile"])}}
    size = re.search(r"## The VRT thesis experiment \(section 6\.1\), (\d+)x(\d+) pixels", text)
    reference = re.search(r"rendered at super-sampling (\d+)x\d+", text)
    thesis = {"width": int(size[1]), "height": int(size[2]), "reference_super_sampling": int(reference[1]),
              "rows": [], "image_error": []}
    seconds = table(found, ["super-sampling", "raylab none s"])
    tests = table(found, ["super-sampling", "raylab none tests"])
    for time_row, test_row in zip(seconds, tests):
        for key in time_row:
            if key.startswith("raylab "):
                structure = key.split(" ")[1]
                thesis["rows"].append({"structure": structure, "super_sampling": int(time_row["super-sampling"]),
                                       "render_seconds_median": number(time_row[key]),
                                       "triangle_tests": int(number(test_row[f"raylab {structure} tests"]))})
    for row in table(found, ["structure", "super-sampling", "render s"]):
        psnr = row["PSNR dB"]
        thesis["image_error"].append({"structure": row["structure"], "super_sampling": int(row["super-sampling"]),
                                      "psnr_db": None if psnr == "inf" else float(psnr)})
    results["thesis"] = thesis
    results["leaks"] = [{"mesh": row["mesh"], "triangles": int(number(row["triangles"])), "triangle_test": row["test"],
                         "contract": row.get("contract", "exact"),
                         "rays": row["rays aimed at"], "ray_count": int(row["rays"]), "escaped": int(row["escaped"]),
                         "rays_per_second": rate(row["rays/s"])}
                        for row in table(found, ["mesh", "triangles", "test"])]
    self_hits = []
    for row in table(found, ["scale"]):
        for method, cell in row.items():
            if method != "scale":
                count, share = re.match(r"(\d+) \(([\d.]+)%\)", cell).groups()
                self_hits.append({"scale": float(row["scale"]), "method": method, "false_self_hits": int(count),
                                  "fraction": float(share) / 100.0})
    results["self_hits"] = {"rows": self_hits}
    animation = re.search(r"^(\S+) \(([\d,]+) triangles\) deformed by `([^`]+)` over (\d+) frames; ([\d,]+) rays",
                          text, re.MULTILINE)
    if animation:
        results["animation"] = {
            "mesh": animation[1], "triangles": int(number(animation[2])), "animation": animation[3],
            "frames": int(animation[4]), "rays": int(number(animation[5])),
            "rows": [{"frame": int(r["frame"]), "rebuild_seconds": number(r["rebuild ms"]) / 1e3,
                      "refit_seconds": number(r["refit ms"]) / 1e3,
                      "rebuilt_trace_seconds": number(r["trace ms after rebuild"]) / 1e3,
                      "refitted_trace_seconds": number(r["after refit"]) / 1e3,
                      "rebuilt_sah_cost": number(r["SAH rebuilt"]), "refitted_sah_cost": number(r["SAH refitted"])}
                     for r in table(found, ["frame", "rebuild ms"])]}
    return results


def main():
    results = results_from_report(REPORT.read_text(encoding="utf-8"))
    for chart, level in PUBLISHED.items():
        target = ROOT / "levels" / level / "diagrams"
        written = write_charts(results, target, only=[chart])
        log(f"redrew {(target / chart).relative_to(ROOT)} from {REPORT.relative_to(ROOT)}" if written else
            f"the report holds no data for {chart}")


if __name__ == "__main__":
    main()
