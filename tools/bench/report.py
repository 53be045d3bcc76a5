"""The benchmark's Markdown report (results.md), and --publish: the charts of a full run into the
levels that show them, the report into docs/bench/."""
import shutil
import sys

from . import ROOT, log
from .experiments import THESIS, thesis_structures
from .run import DISAGREEMENT_KINDS, run_lookup


def fmt_rate(x):
    return "-" if x is None else (f"{x / 1e6:.2f} M" if x >= 1e6 else f"{x / 1e3:.1f} k")


def disagreement_examples(results):
    """One example ray per mesh, structure and kind of disagreement, with both hits re-solved in double
    precision: the referee says which tracer was off, and by how much."""
    def hit(h):
        if h is None:
            return "miss", "-"
        edge = ", on edge" if h["on_edge"] else ""
        return f"{h['triangle']} at t {h['t']:.7g}{edge}", f"{h['double_t']:.9g}"

    lines = ["Examples (the first disagreement of each kind; *double t* is the ray against that triangle solved "
             "in double precision):", "",
             "| mesh | structure | rays | query | kind | raylab hit | double t | Embree hit | double t |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, mesh in results["meshes"].items():
        for t in mesh["tracers"]:
            if t["kind"] != "raylab" or t["error"] or t["name"] not in ("octree", "bvh"):
                continue
            for ray_set, per in t["tracing"]["per_ray_set"].items():
                for query, counts in per["agreement_with_embree"].items():
                    seen = set()
                    for e in counts.get("examples", []):
                        if e["kind"] in seen:
                            continue
                        seen.add(e["kind"])
                        ours, theirs = hit(e["raylab"]), hit(e["embree"])
                        lines.append(f"| {name} | {t['name']} | {ray_set} | {query} | {e['kind']} | {ours[0]} | "
                                     f"{ours[1]} | {theirs[0]} | {theirs[1]} |")
    if len(lines) == 4:
        lines.append("| (no disagreement) | | | | | | | | |")
    return lines + [""]


def animation_markdown(anim):
    """The refit-against-rebuild section: its summary and one row per frame."""
    s = anim["summary"]
    lines = ["## An animation: refit the BVH or rebuild it", "",
             f"{anim['mesh']} ({anim['triangles']:,} triangles) deformed by `{anim['animation']}` over "
             f"{anim['frames']} frames; {anim['rays']:,} rays (camera and random) traced on one thread after each. "
             f"Over frames 1-{anim['frames'] - 1}: rebuild {1e3 * s['rebuild_seconds_median']:.2f} ms and refit "
             f"{1e3 * s['refit_seconds_median']:.2f} ms (medians; refit {s['refit_speedup_median']:.1f}x faster); "
             f"the trace after a refit takes {s['trace_ratio_median']:.2f}x the trace after a rebuild (median), "
             f"{s['trace_ratio_last']:.2f}x at the last frame, where the refitted tree's SAH cost is "
             f"{s['sah_ratio_last']:.2f}x the rebuilt one's. Hits equal on every frame: {s['all_hits_equal']}.", "",
             "| frame | rebuild ms | refit ms | trace ms after rebuild | after refit | SAH rebuilt | SAH refitted |",
             "|---|---|---|---|---|---|---|"]
    for r in anim["rows"]:
        lines.append(f"| {r['frame']} | {1e3 * r['rebuild_seconds']:.2f} | {1e3 * r['refit_seconds']:.2f} | "
                     f"{1e3 * r['rebuilt_trace_seconds']:.2f} | {1e3 * r['refitted_trace_seconds']:.2f} | "
                     f"{r['rebuilt_sah_cost']:.2f} | {r['refitted_sah_cost']:.2f} |")
    return lines + [""]


def builders_markdown(builders):
    """The BVH's builders side by side: one row per mesh and builder."""
    lines = ["## The BVH's builders", "",
             f"Camera rays ({builders['camera']}x{builders['camera']}) and {builders['random_rays']:,} random rays, "
             "closest hit counted on one thread; build: the core's timer, median of "
             f"{builders['reps']}; trace: the camera rays on one thread, median. SAH cost: sah_cost(), lower is "
             "better. Hits equal to the default builder's on every ray: "
             f"{all(r['camera_same_hits'] and r['random_same_hits'] for r in builders['rows'])}.", "",
             "| mesh | builder | build ms | SAH cost | nodes | camera: triangle tests / ray | nodes / ray "
             "| trace ms | random: triangle tests / ray | nodes / ray |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in builders["rows"]:
        lines.append(f"| {r['mesh']} ({r['triangles']:,}) | {r['builder']} | {1e3 * r['build_seconds']:.2f} | "
                     f"{r['sah_cost']:.2f} | {r['nodes']:,} | {r['camera_triangle_tests_per_ray']:.2f} | "
                     f"{r['camera_nodes_per_ray']:.2f} | {1e3 * r['camera_trace_seconds']:.1f} | "
                     f"{r['random_triangle_tests_per_ray']:.2f} | {r['random_nodes_per_ray']:.2f} |")
    return lines + [""]


# The goals of issue 41 through the API, each: what, the target per query (intersect, occluded), the rows it
# reads (contract, ray set), the row's field, and whether the target is a ceiling (ns) or a floor (ratio).
API_GOALS = (
    ("fixed cost per ray, rays missing the root (ns)", (10, 5), (None, "missing_root"), "ns_per_ray", "max"),
    ("exact, camera framing the mesh / Embree single rays", (1.0, 1.0), ("exact", "camera"), "ratio_to_embree_1",
     "min"),
    ("exact, camera with sky / Embree single rays", (1.0, 1.0), ("exact", "camera_sky"), "ratio_to_embree_1", "min"),
    ("exact, random / Embree single rays", (0.9, 0.9), ("exact", "random"), "ratio_to_embree_1", "min"),
    ("exact, camera framing the mesh / Embree packets", (1.0, 1.0), ("exact", "camera"), "ratio_to_embree_8", "min"),
    ("exact, camera with sky / Embree packets", (1.0, 1.0), ("exact", "camera_sky"), "ratio_to_embree_8", "min"),
    ("fast, camera framing the mesh / Embree packets", (1.2, 1.2), ("fast", "camera"), "ratio_to_embree_8", "min"),
    ("fast, camera with sky / Embree packets", (1.2, 1.2), ("fast", "camera_sky"), "ratio_to_embree_8", "min"),
    ("fast, random / Embree single rays", (1.0, 1.0), ("fast", "random"), "ratio_to_embree_1", "min"),
)
API_COLUMNS = (("Structure", "intersect"), ("Scene", "intersect"), ("Structure", "occluded"), ("Scene", "occluded"))
API_SET_WORDS = {"camera": "camera framing the mesh", "camera_sky": "camera with sky around the mesh",
                 "random": "random", "missing_root": "missing the root"}


def api_rows(api):
    return [r for mesh in api["meshes"].values() for r in mesh["rows"]]


def api_goal_lines(api):
    """Issue 41's goals with what the user's path measured: per goal and column the range over the meshes
    (the worst end decides), reached when every column meets its target."""
    rows = api_rows(api)
    lines = ["| goal (through `import raylab`) | target intersect / occluded | "
             + " | ".join(f"{t}.{q}" for t, q in API_COLUMNS) + " | reached |", "|---|---|" + "---|" * 5]
    for what, targets, (contract, ray_set), field, worst in API_GOALS:
        cells, reached = [], True
        for target, query in API_COLUMNS:
            values = [r[field] for r in rows if r["target"] == target and r["query"] == query
                      and r["rays"] == ray_set and (contract is None or r["contract"] == contract)
                      and r.get(field) is not None]
            if not values:
                cells.append("-")
                continue
            goal = targets[0] if query == "intersect" else targets[1]
            bad = max(values) if worst == "max" else min(values)
            reached &= bad <= goal if worst == "max" else bad >= goal
            digits = 1 if worst == "max" else 2
            cells.append(f"{min(values):.{digits}f}-{max(values):.{digits}f}" if len(values) > 1
                         else f"{values[0]:.{digits}f}")
        sign = "<=" if worst == "max" else ">="
        lines.append(f"| {what} | {sign} {targets[0]:g} / {targets[1]:g} | " + " | ".join(cells)
                     + f" | {'yes' if reached else 'no'} |")
    ex = api.get("exactness", {})
    if ex:
        wrong = sum(e["exact_wrong"] for e in ex.values())
        judged = sum(e["exact_judged"] for e in ex.values())
        unexplained = sum(e["unexplained"] for e in ex.values())
        lines.append(f"| exact: wrong answers per million (float64 referee), unexplained disagreements with "
                     f"Embree | 0 / 0 | {1e6 * wrong / max(1, judged):.0f} of {judged:,} judged; "
                     f"{unexplained} unexplained | | | | {'yes' if wrong == 0 and unexplained == 0 else 'no'} |")
    return lines


def api_summary_lines(api):
    """The README's table: per mesh and API target, `intersect`'s ratios to Embree's single rays and packets
    on each ray set and contract, and the fixed cost per ray (exact contract)."""
    lines = ["| mesh (camera hit %: framing / sky) | API | exact / single: camera | sky | random | exact / packets: "
             "camera | sky | fast / packets: camera | sky | fast / single: random | ns per ray missing the root: "
             "intersect | occluded |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, mesh in api["meshes"].items():
        by = {(r["target"], r["contract"], r["rays"], r["query"]): r for r in mesh["rows"]}
        for target in ("Structure", "Scene"):
            get = lambda c, s, k: by[(target, c, s, "intersect")][k]  # noqa: E731
            shares = [100 * get("exact", s, "hit_share") for s in ("camera", "camera_sky")]
            hits = f"{shares[0]:.0f} / {shares[1]:.0f}"
            cells = [get("exact", s, "ratio_to_embree_1") for s in ("camera", "camera_sky", "random")]
            cells += [get("exact", s, "ratio_to_embree_8") for s in ("camera", "camera_sky")]
            cells += [get("fast", s, "ratio_to_embree_8") for s in ("camera", "camera_sky")]
            cells += [get("fast", "random", "ratio_to_embree_1")]
            door = [by[(target, "exact", "missing_root", q)]["ns_per_ray"] for q in ("intersect", "occluded")]
            lines.append(f"| {name} ({by[(target, 'exact', 'camera', 'intersect')]['triangles']:,}; {hits}) "
                         f"| {target} | " + " | ".join("-" if x is None else f"{x:.2f}" for x in cells)
                         + " | " + " | ".join(f"{x:.1f}" for x in door) + " |")
    return lines


def api_markdown(api):
    """The user's path: the goal table, then per mesh every call's rays/s and ratios, then the door."""
    first = next(iter(api["meshes"].values()), {"reps": 0, "pinned_core": None})
    lines = ["## The user's path: `import raylab` against Embree", "",
             f"`raylab.build(V, T, contract=...)` (Structure) and a `raylab.Scene` with one instance, numpy in and "
             f"numpy out, `threads=1`, this process pinned to one core (core {first['pinned_core']}), "
             f"{first['reps']} interleaved rounds of every call, medians ({first.get('clock', 'wall clock')}, as "
             "raylab_bench's), on every ray raylab_bench traced (its "
             "camera framing the mesh, its camera with sky around the mesh, its random rays), right after "
             "raylab_bench's run on the same mesh, whose one-thread medians (its one-thread runs pinned too) give "
             "Embree 3 medium's single rays (`rtcIntersect1` / `rtcOccluded1`) and packets (`rtcIntersect8` / "
             "`rtcOccluded8` over each run of 8 consecutive rays, coherent), and raylab's C++ core (the BVH in the "
             "same contract). Ratios: rays per second, above 1 is raylab faster; `intersect` against Embree's "
             "closest hit, `occluded` against its occlusion.", ""]
    lines += api_goal_lines(api) + [""]
    lines += ["Per mesh (`intersect`, ratios of rays per second; the README's table):", ""]
    lines += api_summary_lines(api) + ["", "Every call:", ""]
    lines += ["| mesh | rays (hit) | contract | query | Structure Mrays/s | Scene | C++ core | Embree single "
              "| Embree packets | Structure / single | / packets | Scene / single | / packets | Structure / C++ |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    rate = lambda x: "-" if x is None else f"{x / 1e6:.2f}"  # noqa: E731
    ratio = lambda x: "-" if x is None else f"{x:.2f}"  # noqa: E731
    for name, mesh in api["meshes"].items():
        by = {(r["target"], r["contract"], r["rays"], r["query"]): r for r in mesh["rows"]}
        for (target, contract, ray_set, query), r in by.items():
            if target != "Structure" or ray_set == "missing_root":
                continue
            scene = by[("Scene", contract, ray_set, query)]
            lines.append(f"| {name} ({r['triangles']:,}) | {API_SET_WORDS[ray_set]} ({100 * r['hit_share']:.0f} %) "
                         f"| {contract} | {query} | {rate(r['rays_per_second'])} | {rate(scene['rays_per_second'])} "
                         f"| {rate(r['core_rays_per_second'])} | {rate(r['embree_1_rays_per_second'])} "
                         f"| {rate(r['embree_8_rays_per_second'])} | {ratio(r['ratio_to_embree_1'])} "
                         f"| {ratio(r['ratio_to_embree_8'])} | {ratio(scene['ratio_to_embree_1'])} "
                         f"| {ratio(scene['ratio_to_embree_8'])} | {ratio(r['ratio_to_core'])} |")
    lines += ["", "The door: what a call costs per ray before any box test, on as many rays as the camera's, all "
              "beyond the mesh's box looking away (ns per ray, exact / fast contract).", "",
              "| mesh | rays | " + " | ".join(f"{t}.{q}" for t, q in API_COLUMNS) + " |", "|---|---|---|---|---|---|"]
    for name, mesh in api["meshes"].items():
        by = {(r["target"], r["contract"], r["rays"], r["query"]): r for r in mesh["rows"]}
        cells = [" / ".join(f"{by[(t, c, 'missing_root', q)]['ns_per_ray']:.1f}" for c in ("exact", "fast"))
                 for t, q in API_COLUMNS]
        n = by[("Structure", "exact", "missing_root", "intersect")]["ray_count"]
        lines.append(f"| {name} | {n:,} | " + " | ".join(cells) + " |")
    ex = api.get("exactness", {})
    if ex:
        lines += ["", "Embree's packets against its single rays on the same scene, closest hits differing (triangle "
                  "or t, u, v bit for bit) over every ray set raylab_bench checked: "
                  + ", ".join(f"{name} {e['embree_packets_differ_from_single']}" for name, e in ex.items())
                  + " (only rays aimed exactly at edges and vertices differ: Embree's test is not watertight, and "
                  "its packet and single-ray kernels round such a ray apart)."]
    return lines + [""]


def render_markdown(render):
    """F12's renderer against the baseline checkout's: one row per scene and super sampling."""
    lines = ["## F12's renderer against the baseline's", "",
             f"`raylab.render` on one thread, one core pinned, against the renderer of `{render['baseline']}`: "
             f"each render in its own process, the two alternating ({render['rounds']} rounds; renders per "
             "process: " + ", ".join(f"{k} {v}" for k, v in render["renders_per_process"].items())
             + "), medians; speed-up = the baseline's seconds / this checkout's (above 1: faster), by the "
             "renderer's own timer and by process CPU time. Exact contract, one point light with shadows, "
             "recursion 3.", "",
             "| scene | pixels | super sampling | baseline s | this s | speed-up | CPU-time speed-up |",
             "|---|---|---|---|---|---|---|"]
    for r in render["rows"]:
        lines.append(f"| {r['scene']} ({r['triangles']:,} triangles) | {r['width']} x {r['height']} "
                     f"| {r['super_sampling']} | {r['baseline_render_seconds_median']:.3f} "
                     f"| {r['this_render_seconds_median']:.3f} | {r['speedup_render_seconds']:.2f} "
                     f"| {r['speedup_cpu_seconds']:.2f} |")
    return lines + [""]


def summary_lines(results):
    """The BVH against Embree (medium) per mesh and thread count, from the ratios add_ratios made: the
    table the README quotes."""
    lines = ["## Summary", "",
             "BVH/Embree medium: rays per second, above 1 is faster; build: seconds, above 1 is slower; "
             "the octree's camera rays (closest hit) against the BVH's.", "",
             "| mesh | threads | BVH/Embree camera closest | camera any | random closest | random any | build "
             "| bytes/tri BVH / Embree | octree/BVH camera closest | BVH/Embree packets camera closest "
             "| camera with sky closest |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, mesh in results["meshes"].items():
        tracers = {t["name"]: t for t in mesh["tracers"]}
        bvh, octree, embree = tracers.get("bvh"), tracers.get("octree"), tracers.get("embree_medium")
        if not bvh or not embree or bvh["error"] or embree["error"]:
            continue
        r = bvh["ratios_to_embree_medium"]
        octree_r = octree.get("ratios_to_embree_medium", {}) if octree and not octree["error"] else {}
        per_triangle = (f"{bvh['memory_bytes'] / mesh['triangles']:.1f} / "
                        f"{embree['memory_bytes'] / mesh['triangles']:.1f}")
        for threads in sorted(int(n) for n in bvh["build"]):
            rays = [r.get(f"{s}_{q}_{threads}t_rays_per_second") for s, q in
                    (("camera", "closest"), ("camera", "any"), ("random", "closest"), ("random", "any"))]
            camera_octree = octree_r.get(f"camera_closest_{threads}t_rays_per_second")
            cells = [f"{x:.2f}" if x is not None else "-" for x in rays + [r[f"build_{threads}t_seconds"]]]
            cells += [per_triangle, f"{camera_octree / rays[0]:.2f}" if camera_octree and rays[0] else "-"]
            packets = bvh.get("ratios_to_embree_packets", {})
            cells += [f"{x:.2f}" if x is not None else "-" for x in
                      (packets.get(f"camera_closest_{threads}t_rays_per_second"),
                       packets.get(f"camera_sky_closest_{threads}t_rays_per_second"))]
            lines.append(f"| {name} | {threads} | " + " | ".join(cells) + " |")
    return lines + [""]


PRICE_RUNS = (("camera", "closest"), ("camera", "any"), ("shadow", "any"), ("random", "closest"), ("random", "any"))
VERDICT_WORDS = {"off_triangle": "off its triangle", "outside_interval": "outside (tmin, tmax]",
                 "missed_inside": "a hit inside a triangle missed", "leaked": "leaked through an edge or vertex"}


def price_lines(results):
    """The price of exactness: each judged tracer's speed against Embree (medium, one thread) beside its
    wrong answers per million as the float64 referee counts them, per ray set; then the hostile rays by
    kind."""
    lines = ["## The price of exactness", "",
             "Rays per second against Embree medium on one thread (above 1 is faster), and wrong answers per "
             "million rays as the float64 referee of native/bench/arbitration.h judges them: a hit off its "
             "triangle or outside (tmin, tmax], a hit inside a triangle missed, a ray leaked through an edge or "
             "vertex where it crosses the surface. Ties within 4 float steps of an edge or of tmax are right "
             "either way.", "",
             "| mesh | tracer | " + " | ".join(f"{s} {q}" for s, q in PRICE_RUNS)
             + " | wrong/M camera | shadow | random | hostile |",
             "|---|---|" + "---|" * (len(PRICE_RUNS) + 4)]
    for name, mesh in results["meshes"].items():
        tracers = {t["name"]: t for t in mesh["tracers"]}
        embree = tracers.get("embree_medium", {})
        for t in mesh["tracers"]:
            if t["error"] or not t.get("exactness"):
                continue
            ratios = []
            for ray_set, query in PRICE_RUNS:
                ours, theirs = run_lookup(t, ray_set, query, 1), run_lookup(embree, ray_set, query, 1)
                ratios.append(f"{ours['rays_per_second'] / theirs['rays_per_second']:.2f}" if ours and theirs
                              else "-")
            wrong = [f"{t['exactness'][s]['wrong_per_million']:,.0f}" if s in t["exactness"] else "-"
                     for s in ("camera", "shadow", "random", "hostile")]
            lines.append(f"| {name} | {t['name']} | " + " | ".join(ratios + wrong) + " |")
    kinds = next((m["ray_sets"]["hostile"]["kinds"] for m in results["meshes"].values()
                  if "hostile" in m.get("ray_sets", {})), None)
    if kinds:
        lines += ["", "Hostile rays by kind: wrong answers / rays of the kind, and what they were.", "",
                  "| mesh | tracer | " + " | ".join(kinds) + " | wrong answers |",
                  "|---|---|" + "---|" * (len(kinds) + 1)]
        for name, mesh in results["meshes"].items():
            for t in mesh["tracers"]:
                hostile = (t.get("exactness") or {}).get("hostile")
                if t["error"] or not hostile:
                    continue
                by = hostile["by_kind"]
                what = ", ".join(f"{hostile[v]} {words}" for v, words in VERDICT_WORDS.items() if hostile[v])
                cells = [f"{by[k]['wrong']}/{by[k]['rays']}" for k in kinds]
                lines.append(f"| {name} | {t['name']} | " + " | ".join(cells) + f" | {what or 'none'} |")
    return lines + [""]


def markdown(results):
    lines = ["# raylab benchmark", "",
             f"{results['machine']['date']}, {results['machine']['hardware_threads']} hardware threads, "
             f"Embree {results['machine']['embree']}, Blender {results['blender'].get('blender_version', '-')}. "
             "Rays/s are medians of repetitions in this run; ratios are raylab / Embree (medium quality) "
             "on the same rays.", ""]
    if results.get("api"):  # the headline: what a user gets
        lines += api_markdown(results["api"])
    lines += summary_lines(results)
    lines += price_lines(results)
    lines += ["## Throughput, build and memory", "",
              "| mesh | tris | tracer | build s (2t) | bytes/tri | camera closest 1t | 2t | camera any 2t "
              "| random closest 1t | 2t | random any 2t | boxes/ray | tris/ray | BVH/Embree camera | random | build |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, mesh in results["meshes"].items():
        for t in mesh["tracers"]:
            if t["error"]:
                lines.append(f"| {name} | {mesh['triangles']:,} | {t['name']} | error: {t['error']} |" + " |" * 12)
                continue
            rate = lambda s, q, n: (run_lookup(t, s, q, n) or {}).get("rays_per_second")  # noqa: E731
            counts = t["tracing"]["per_ray_set"].get("camera", {}).get("counts", {}).get("closest")
            r = t.get("ratios_to_embree_medium", {})
            tests = (f"| {counts['box_tests_per_ray']:.1f} | {counts['triangle_tests_per_ray']:.1f} " if counts
                     else "| - | - ")
            lines.append(
                f"| {name} | {mesh['triangles']:,} | {t['name']} | {t['build']['2']['seconds_median']:.4f} "
                f"| {t['memory_bytes'] / mesh['triangles']:.1f} "
                f"| {fmt_rate(rate('camera', 'closest', 1))} | {fmt_rate(rate('camera', 'closest', 2))} "
                f"| {fmt_rate(rate('camera', 'any', 2))} | {fmt_rate(rate('random', 'closest', 1))} "
                f"| {fmt_rate(rate('random', 'closest', 2))} | {fmt_rate(rate('random', 'any', 2))} " + tests)
            if r:
                lines[-1] += (f"| {r['camera_closest_2t_rays_per_second']:.2f} "
                              f"| {r['random_closest_2t_rays_per_second']:.2f} "
                              f"| {r['build_2t_seconds']:.2f} |")
            else:
                lines[-1] += "| | | |"
        b = results["blender"].get("meshes", {}).get(name)
        if b:
            rs = b["ray_sets"]
            lines.append(f"| {name} | {mesh['triangles']:,} | Blender BVHTree (Python loop) | "
                         f"{b['build']['seconds_median']:.4f} (1t) | - | {fmt_rate(rs['camera']['rays_per_second'])} "
                         f"| - | - | {fmt_rate(rs['random']['rays_per_second'])} | - | - | - | - "
                         f"| {rs['camera']['ratio_to_embree_medium_1t']:.2f} (1t) "
                         f"| {rs['random']['ratio_to_embree_medium_1t']:.2f} (1t) "
                         f"| {b['build']['ratio_to_embree_medium']:.2f} (1t) |")
    lines += ["", "Rays that raylab's `none` and `aabb` trace are a spread subset of each set (they are O(T) "
              "per ray); each tracer's rays/s is over the rays it traced. Blender's BVHTree is a Python loop "
              "of `ray_cast` on one thread (it has no any-hit query), on a subset of the same rays.", ""]
    lines += ["## Hits compared with Embree on every benchmark ray", "",
              "| mesh | tracer | rays | query | " + " | ".join(DISAGREEMENT_KINDS) + " |",
              "|---|---|---|---|" + "---|" * len(DISAGREEMENT_KINDS)]
    for name, mesh in results["meshes"].items():
        for t in mesh["tracers"]:
            if t["kind"] != "raylab" or t["error"]:
                continue
            for ray_set, per in t["tracing"]["per_ray_set"].items():
                for query, counts in per["agreement_with_embree"].items():
                    lines.append(f"| {name} | {t['name']} | {ray_set} | {query} | "
                                 + " | ".join(str(counts.get(k, 0)) for k in DISAGREEMENT_KINDS) + " |")
        for ray_set, b in results["blender"].get("meshes", {}).get(name, {}).get("ray_sets", {}).items():
            c = b["agreement_with_embree"]
            lines.append(f"| {name} | Blender BVHTree | {ray_set} | closest | "
                         + " | ".join(str(c.get(k, 0)) for k in DISAGREEMENT_KINDS) + " |")
    lines += ["", "Kinds: *same* (both miss, or the same triangle at t within 1e-5 relative); *rounding* (the same "
              "triangle, t differs, but both hit points lie on its plane within 1e-6 of the coordinates' magnitude: a "
              "slide along the face, which a short t or a grazing ray magnifies); *shared_edge_vertex* (different "
              "triangles sharing a vertex at the same point, on an edge of both: an exact edge or vertex hit owned "
              "by both); *coincident_faces* (different triangles without a shared vertex at the same point: "
              "overlapping faces); *edge_ray* (the row's tracer hits a triangle on its edge, within 1e-5 "
              "barycentric or 1e-6 of the magnitude of the corners and the ray origin, where Embree misses or hits "
              "farther: "
              "Embree's default test is not watertight); *edge_ray_passed* (the reverse: Embree hits an edge the "
              "row's tracer passes); "
              "*grazing* (same triangle, t differs, ray almost parallel to the face); where none of these fits, the "
              "float64 referee settles it: *embree_wrong* (it judges Embree's answer wrong and the row's right), "
              "*raylab_wrong* (the reverse; never for the exact contract), *referee_tie* (both right: within its tie "
              "distance of an edge or of tmax); *unexplained*.", ""]
    lines += disagreement_examples(results)
    th = results["thesis"]
    structures = thesis_structures(th)
    lines += [f"## The VRT thesis experiment (section 6.1), {th['width']}x{th['height']} pixels", "",
              th["note"] + ".", "",
              "| super-sampling | " + " | ".join(f"raylab {s} s" for s in structures)
              + " | thesis none s | thesis aabb s | thesis octree s |", "|---|" + "---|" * (len(structures) + 3)]
    by = {(r["structure"], r["super_sampling"]): r for r in th["rows"]}
    for i, ss in enumerate(sorted({r["super_sampling"] for r in th["rows"]})):
        thesis = [THESIS["render_seconds"][s][i] if i < 3 else None for s in ("none", "aabb", "octree")]
        lines.append(f"| {ss} | " + " | ".join(f"{by[(s, ss)]['render_seconds_median']:.4f}" for s in structures)
                     + " | " + " | ".join("-" if x is None else f"{x:.4f}" for x in thesis) + " |")
    lines += ["", "| super-sampling | " + " | ".join(f"raylab {s} tests" for s in structures)
              + " | thesis none | thesis aabb | thesis octree |", "|---|" + "---|" * (len(structures) + 3)]
    for i, ss in enumerate(sorted({r["super_sampling"] for r in th["rows"]})):
        thesis = [THESIS["triangle_tests"][s][i] if i < 3 else None for s in ("none", "aabb", "octree")]
        lines.append(f"| {ss} | " + " | ".join(f"{by[(s, ss)]['triangle_tests']:,}" for s in structures)
                     + " | " + " | ".join("-" if x is None else f"{x:,}" for x in thesis) + " |")
    if th.get("image_error"):
        lines += ["", f"Image error against the reference, the same scene rendered at super-sampling "
                  f"{th['reference_super_sampling']}x{th['reference_super_sampling']}:", "",
                  "| structure | super-sampling | render s | RMSE | PSNR dB | max diff to other structures |",
                  "|---|---|---|---|---|---|"]
        for e in th["image_error"]:
            r = by[(e["structure"], e["super_sampling"])]
            psnr = f"{e['psnr_db']:.1f}" if e["psnr_db"] else "inf"
            lines.append(f"| {e['structure']} | {e['super_sampling']} | {r['render_seconds_median']:.4f} "
                         f"| {e['rmse']:.5f} | {psnr} | {e['max_difference_to_other_structures']:.2g} |")
    lines += ["", "## Rays escaping closed meshes from inside", "",
              "| mesh | triangles | test | contract | rays aimed at | rays | escaped | rays/s |",
              "|---|---|---|---|---|---|---|---|"]
    for r in results["leaks"]:
        exact = r.get("contract", "exact") == "exact"  # another contract brings its own test
        lines.append(f"| {r['mesh']} | {r['triangles']:,} | {r['triangle_test'] if exact else 'its own'} "
                     f"| {r.get('contract', 'exact')} "
                     f"| {r['rays']} | {r['ray_count']} "
                     f"| {r['escaped']} | {fmt_rate(r['rays_per_second'])} |")
    sh = results["self_hits"]
    lines += ["", "## False self-hits of shadow rays against scene scale", ""]
    methods = list(dict.fromkeys(r["method"] for r in sh["rows"]))
    lines += ["Convex sphere, sun light: every lit pixel darkened by its own shadow ray is a false self-hit "
              "(share of lit pixels).", "", "| scale | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
    for scale in dict.fromkeys(r["scale"] for r in sh["rows"]):
        cells = [next(r for r in sh["rows"] if r["scale"] == scale and r["method"] == m) for m in methods]
        lines.append(f"| {scale:g} | " + " | ".join(f"{c['false_self_hits']} ({100 * c['fraction']:.1f}%)"
                                                   for c in cells) + " |")
    if results.get("render"):
        lines += [""] + render_markdown(results["render"])
    if results.get("animation"):
        lines += [""] + animation_markdown(results["animation"])
    if results.get("builders"):
        lines += [""] + builders_markdown(results["builders"])
    lines += ["", "Charts: " + ", ".join(f"`{c}`" for c in results["charts"]), ""]
    return "\n".join(lines)


# Where each chart is shown: the level folders hold them as diagrams (the installed add-on carries the
# levels), and the README embeds them from there; the full table goes to docs/bench/results.md.
PUBLISHED = {"bench_throughput.png": "race", "bench_embree_ratio.png": "race", "bench_thesis.png": "race",
             "bench_speed_accuracy.png": "race", "bench_leaks.png": "where_methods_fail",
             "bench_price.png": "where_methods_fail",
             "bench_self_hits.png": "where_methods_fail", "bench_animation.png": "race"}


def publish(results, out):
    if results["configuration"] != "full":
        sys.exit("bench: --publish takes the charts of a full run (./raylab bench without --quick)")
    for chart, level in PUBLISHED.items():
        target = ROOT / "levels" / level / "diagrams" / chart
        shutil.copyfile(out / chart, target)
        log(f"published {target.relative_to(ROOT)}")
    shutil.copyfile(out / "results.md", ROOT / "docs" / "bench" / "results.md")
    log("published docs/bench/results.md")
    # The user's path run alone (--only api, CPU-timed on both sides: the README's tables) when there is one.
    if (out / "api.md").exists():
        shutil.copyfile(out / "api.md", ROOT / "docs" / "bench" / "api.md")
        log("published docs/bench/api.md")
