"""The benchmark's charts (bench_*.png, matplotlib without a display), drawn for the levels' Tutorial
panel that shows them (tools/panel_figure.py): squares one under the other, every text readable at the
sidebar's width, few words (the level's text and results.md say the rest)."""
import numpy as np
from matplotlib.lines import Line2D
from matplotlib.ticker import NullLocator

import raylab

from .. import panel_figure as page
from ..panel_figure import SMALL_PT
from .experiments import THESIS, leak_method, thesis_structures
from .run import run_lookup

MESH_COLORS = ["#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02"]
STRUCTURE_COLORS = {"none": "#7f7f7f", "aabb": "#2ca02c", "octree": "#ff7f0e", "bvh": "#1f77b4", "grid": "#9467bd"}
TRACER_LABELS = {"embree_medium": "Embree med.", "embree_packets": "Embree pkt.", "embree_high": "Embree high"}


def short_count(x):
    """1500 -> "1.5k", 2e6 -> "2M": tick labels and legend entries that fit the panel."""
    for size, suffix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if abs(x) >= size:
            return f"{x / size:.3g}{suffix}"
    return f"{x:.3g}"


def log_axis(ax, axis, data, formatter=short_count, most=4):
    """A log axis over the decades the data spans, at most `most` labelled decade ticks, written without
    exponents (mathtext's are too small for the panel), no minor ticks."""
    data = [v for v in data if v and v > 0]
    low, high = int(np.floor(np.log10(min(data)))), int(np.ceil(np.log10(max(data))))
    high = max(high, low + 1)
    step = int(np.ceil((high - low + 1) / most))
    getattr(ax, f"set_{axis}scale")("log")
    getattr(ax, f"set_{axis}lim")(10.0 ** low, 10.0 ** high)
    getattr(ax, f"{axis}axis").set_minor_locator(NullLocator())
    # Fewer ticks until the labels do not touch on the axis as drawn ("100k10M" on a narrow panel).
    while True:
        values = [10.0 ** e for e in range(low, high + 1, step)]
        getattr(ax, f"set_{axis}ticks")(values, [formatter(v) for v in values])
        if len(values) <= 2 or not labels_overlap(ax, axis):
            return
        step += 1


def labels_overlap(ax, axis, gap_px=4.0):
    """Whether any two tick labels of ax's `axis` come closer than gap_px pixels when drawn."""
    renderer = ax.figure.canvas.get_renderer()
    labels = [t for t in getattr(ax, f"get_{axis}ticklabels")() if t.get_text()]
    boxes = sorted((t.get_window_extent(renderer) for t in labels), key=lambda b: b.x0 if axis == "x" else b.y0)
    if axis == "x":
        return any(b.x0 - a.x1 < gap_px for a, b in zip(boxes, boxes[1:]))
    return any(b.y0 - a.y1 < gap_px for a, b in zip(boxes, boxes[1:]))


def seconds_label(x):
    return f"{x * 1e3:g} ms" if x < 1 else f"{x:g} s"


def mesh_legend(fig, tile, meshes, results, top=0.14):
    """The meshes' colours by their triangle counts, in one row under the chart."""
    handles = [Line2D([], [], ls="", marker="o", ms=10, color=MESH_COLORS[i]) for i in range(len(meshes))]
    labels = [short_count(results["meshes"][m]["triangles"]) for m in meshes]
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, page.y(fig, tile, top)), ncol=3,
               frameon=False, handletextpad=0.1, columnspacing=0.8, title="triangles in the mesh")


def chart_throughput(results, path):
    """Closest-hit rays per second (2 threads; Blender's BVHTree on 1) of every tracer on every mesh: a
    row per tracer, a dot per mesh. A square for camera rays, one for random rays."""
    meshes = list(results["meshes"])
    names = list(raylab.STRUCTURES) + ["embree_medium", "embree_packets", "embree_high"]
    fig = page.figure(2)
    for tile, ray_set in enumerate(("camera", "random")):
        page.title(fig, tile, f"{ray_set} rays per second")
        ax = fig.add_axes(page.rect(fig, tile, 0.44, 0.43, 0.47, 0.45))
        rows = names + ["blender"]
        for i, m in enumerate(meshes):
            tracers = {x["name"]: x for x in results["meshes"][m]["tracers"]}
            for row, tracer in enumerate(names):
                t = tracers.get(tracer)
                run = run_lookup(t, ray_set, "closest", 2) if t and not t["error"] else None
                if run:
                    ax.plot(run["rays_per_second"], row, "o", color=MESH_COLORS[i], ms=10, alpha=0.85)
            blender = results["blender"].get("meshes", {}).get(m, {}).get("ray_sets", {}).get(ray_set, {})
            if blender.get("rays_per_second"):
                ax.plot(blender["rays_per_second"], len(names), "o", color=MESH_COLORS[i], ms=10, alpha=0.85)
        log_axis(ax, "x", [x for line in ax.get_lines() for x in line.get_xdata()])
        ax.set_yticks(range(len(rows)), [TRACER_LABELS.get(n, n) for n in names] + ["Blender (1t)"])
        ax.set_ylim(len(rows) - 0.5, -0.5)
        ax.grid(axis="x", alpha=0.4)
        mesh_legend(fig, tile, meshes, results, top=0.31)
    return _save(fig, path)


def chart_ratios(results, path):
    """raylab's BVH against Embree (medium) on the same rays, 2 threads: every ratio turned so that
    right of 1 is raylab better (rays per second ours / theirs; build time and memory theirs / ours)."""
    meshes = list(results["meshes"])
    # (ratio key, label, inverse, against Embree's packets rather than its single rays)
    keys = [("camera_closest_2t_rays_per_second", "camera", False),
            ("camera_closest_2t_rays_per_second", "camera/pkt.", False, True),
            ("camera_any_2t_rays_per_second", "camera any", False),
            ("random_closest_2t_rays_per_second", "random", False),
            ("random_any_2t_rays_per_second", "random any", False),
            ("build_2t_seconds", "build speed", True), ("memory_bytes", "less memory", True)]
    fig = page.figure(1)
    page.title(fig, 0, f"raylab BVH / Embree {results['machine']['embree'].split('.')[0]}")
    page.note(fig, 0, 0.5, 0.885, "right of 1: raylab better", ha="center", size=SMALL_PT)
    ax = fig.add_axes(page.rect(fig, 0, 0.44, 0.43, 0.52, 0.38))
    for i, m in enumerate(meshes):
        bvh = {x["name"]: x for x in results["meshes"][m]["tracers"]}.get("bvh", {})
        for row, (key, _, inverse, *packets) in enumerate(keys):
            ratios = bvh.get("ratios_to_embree_packets" if packets else "ratios_to_embree_medium", {})
            if ratios.get(key):
                ax.plot(1.0 / ratios[key] if inverse else ratios[key], row, "o", color=MESH_COLORS[i], ms=10,
                        alpha=0.85)
    ax.axvline(1.0, color="black", lw=2)
    ax.set_xlim(0.4, 1.8)
    ax.set_xticks([0.5, 1.0, 1.5])
    ax.set_yticks(range(len(keys)), [label for _, label, *_ in keys])
    ax.set_ylim(len(keys) - 0.5, -0.5)
    ax.grid(axis="x", alpha=0.4)
    mesh_legend(fig, 0, meshes, results, top=0.31)
    return _save(fig, path)


def structure_legend(fig, tile, structures, top, extra=()):
    """The structures' colours (and `extra` (handle, label) pairs) in rows of three under the chart."""
    handles = [Line2D([], [], color=STRUCTURE_COLORS.get(s, "black"), marker="o", lw=3) for s in structures]
    handles += [handle for handle, _ in extra]
    fig.legend(handles, list(structures) + [label for _, label in extra], loc="upper center",
               bbox_to_anchor=(0.5, page.y(fig, tile, top)), ncol=3, frameon=False, handlelength=1.4,
               handletextpad=0.4, columnspacing=0.8)


def chart_thesis(results, path):
    """The VRT thesis's experiment: render time and triangle tests against super-sampling, raylab's
    structures solid, the thesis's own numbers dashed."""
    th = results["thesis"]
    levels = sorted({r["super_sampling"] for r in th["rows"]})
    by = {(r["structure"], r["super_sampling"]): r for r in th["rows"]}
    structures = thesis_structures(th)
    fig = page.figure(2)
    for tile, (key, thesis_key, title) in enumerate((("render_seconds_median", "render_seconds", "render time"),
                                                     ("triangle_tests", "triangle_tests", "triangle tests"))):
        page.title(fig, tile, f"goat head: {title}")
        ax = fig.add_axes(page.rect(fig, tile, 0.27, 0.43, 0.69, 0.43))
        for s in structures:
            ax.plot(levels, [by[(s, ss)][key] for ss in levels], "o-", color=STRUCTURE_COLORS.get(s), lw=3)
        for s in ("none", "aabb", "octree"):
            ax.plot([1, 2, 3], THESIS[thesis_key][s], "x--", color=STRUCTURE_COLORS[s], lw=2.5, ms=11, mew=3)
        log_axis(ax, "y", [y for line in ax.get_lines() for y in line.get_ydata()],
                 formatter=seconds_label if tile == 0 else short_count, most=5)
        ax.set_xticks(levels, [f"{n}x{n}" for n in levels])
        ax.set_xlabel("samples per pixel", labelpad=2)
        ax.grid(which="major", alpha=0.4)
        thesis = Line2D([], [], color="black", ls="--", marker="x", lw=2.5, ms=11, mew=3)
        structure_legend(fig, tile, structures, top=0.265, extra=[(thesis, "thesis")])
    return _save(fig, path)


def chart_speed_accuracy(results, path):
    """Render time against PSNR: every structure renders the same images, so each is one curve shifted
    in time; the super-sampling is written beside each level."""
    th = results["thesis"]
    by = {(r["structure"], r["super_sampling"]): r for r in th["rows"]}
    structures = thesis_structures(th)
    fig = page.figure(1)
    page.title(fig, 0, "speed against accuracy")
    ax = fig.add_axes(page.rect(fig, 0, 0.23, 0.42, 0.6, 0.45))
    levels = {}
    for s in structures:
        points = [(by[(s, e["super_sampling"])]["render_seconds_median"], e["psnr_db"], e["super_sampling"])
                  for e in th["image_error"] if e["structure"] == s and e["psnr_db"] is not None]
        if points:
            ax.plot([p[0] for p in points], [p[1] for p in points], "o-", color=STRUCTURE_COLORS.get(s), lw=3)
            levels.update({p[2]: p[1] for p in points})
    log_axis(ax, "x", [x for line in ax.get_lines() for x in line.get_xdata()], formatter=seconds_label, most=3)
    ax.set_xlabel("render time", labelpad=2)
    ax.set_ylabel("PSNR (dB)")
    for ss, psnr in sorted(levels.items()):
        ax.text(1.02, psnr, f"{ss}x{ss}", transform=ax.get_yaxis_transform(), va="center", fontsize=SMALL_PT)
    ax.grid(which="major", alpha=0.4)
    structure_legend(fig, 0, structures, top=0.2)
    return _save(fig, path)


MESH_NAMES = {"goathead": "goat", "icosphere": "sphere"}


LEAK_LABELS = {"moller_trumbore": "Möller–Trumbore", "fast": "fast"}
LEAK_COLORS = {"watertight": "#2ca02c", "moller_trumbore": "#d62728", "fast": "#ff7f0e"}


def chart_leaks(results, path):
    """Rays from inside closed meshes that escape (Möller–Trumbore; the watertight test lets none out,
    the fast contract's count in a note), and each method's rays per second on the same rays."""
    rows = results["leaks"]
    meshes = list(dict.fromkeys(r["mesh"] for r in rows))
    kinds = list(dict.fromkeys(r["rays"] for r in rows))
    tests = list(dict.fromkeys(leak_method(r) for r in rows))
    fig = page.figure(2)
    leaky = "moller_trumbore"
    page.title(fig, 0, "Möller–Trumbore:\nrays that escape")
    ax = fig.add_axes(page.rect(fig, 0, 0.2, 0.42, 0.76, 0.38))
    width = 0.8 / len(kinds)
    for k, kind in enumerate(kinds):
        values = [100.0 * r["escaped"] / r["ray_count"] for m in meshes for r in rows
                  if r["mesh"] == m and r["rays"] == kind and leak_method(r) == leaky]
        ax.bar(np.arange(len(meshes)) + (k - (len(kinds) - 1) / 2) * width, values, width, label=kind,
               color=MESH_COLORS[k + 3])
    ax.set_xticks(range(len(meshes)), [MESH_NAMES.get(m, m) for m in meshes])
    ax.set_ylabel("% of the rays")
    ax.grid(axis="y", alpha=0.4)
    ax.legend(loc="upper center", bbox_to_anchor=(0.4, -0.13), ncol=3, frameon=False, handlelength=1.0,
              handletextpad=0.3, columnspacing=0.7, title="rays aimed at")
    watertight = sum(r["escaped"] for r in rows if leak_method(r) == "watertight")
    fast = [r for r in rows if leak_method(r) == "fast"]
    note = f"watertight: {watertight} escape"
    if fast:
        share = 100.0 * sum(r["escaped"] for r in fast) / sum(r["ray_count"] for r in fast)
        note = f"watertight {watertight}, fast {share:.2g} %"  # the title says what they count
    page.note(fig, 0, 0.5, 0.09, note, ha="center", color="#2ca02c")
    page.title(fig, 1, "million rays per second\n(BVH, all its rays)", size=page.TEXT_PT)
    ax = fig.add_axes(page.rect(fig, 1, 0.2, 0.3, 0.76, 0.5))
    width = 0.8 / len(tests)
    for t, test in enumerate(tests):
        # Over all of a mesh's rays: each kind traced the same number, so the rate over all of them is
        # their count over the sum of the kinds' times.
        values = []
        for m in meshes:
            sel = [r for r in rows if r["mesh"] == m and leak_method(r) == test]
            seconds = sum(r["ray_count"] / r["rays_per_second"] for r in sel)
            values.append(sum(r["ray_count"] for r in sel) / seconds / 1e6)
        ax.bar(np.arange(len(meshes)) + (t - (len(tests) - 1) / 2) * width, values, width,
               label=LEAK_LABELS.get(test, test), color=LEAK_COLORS.get(test, "#7f7f7f"))
    ax.set_xticks(range(len(meshes)), [MESH_NAMES.get(m, m) for m in meshes])
    ax.grid(axis="y", alpha=0.4)
    ax.legend(loc="upper center", bbox_to_anchor=(0.4, -0.13), ncol=1 if len(tests) < 3 else 2, frameon=False,
              handlelength=1.0, handletextpad=0.3, columnspacing=0.7)
    return _save(fig, path)


PRICE_TRACERS = {"bvh": ("exact", "#1f77b4", "o"), "bvh_fast": ("fast", "#ff7f0e", "s"),
                 "embree_medium": ("Embree med.", "#444444", "^"), "embree_high": ("Embree high", "#999999", "v")}
ZERO_AT = 0.3  # where "0 wrong per million" sits on the log axis


def chart_price(results, path):
    """The price of exactness: speed against Embree medium (closest hit, one thread) over wrong answers per
    million on the hostile rays, a point per mesh and tracer; camera rays above, random rays below."""
    meshes = list(results["meshes"])
    fig = page.figure(2)
    for tile, ray_set in enumerate(("camera", "random")):
        page.title(fig, tile, f"{ray_set} rays")
        ax = fig.add_axes(page.rect(fig, tile, 0.24, 0.36, 0.7, 0.5))
        ratios = []
        for m in meshes:
            tracers = {t["name"]: t for t in results["meshes"][m]["tracers"]}
            embree = run_lookup(tracers.get("embree_medium", {}), ray_set, "closest", 1)
            for name, (_, color, marker) in PRICE_TRACERS.items():
                t = tracers.get(name)
                run = run_lookup(t, ray_set, "closest", 1) if t and not t["error"] else None
                hostile = (t or {}).get("exactness", {}).get("hostile")
                if run and embree and hostile:
                    wrong = hostile["wrong_per_million"]
                    ratios.append(run["rays_per_second"] / embree["rays_per_second"])
                    ax.plot(wrong if wrong > 0 else ZERO_AT, ratios[-1], marker, color=color, ms=11, alpha=0.85)
        ax.set_xscale("log")
        ax.set_xlim(ZERO_AT / 2, 4e5)
        ax.set_xticks([ZERO_AT, 10, 1e3, 1e5], ["0", "10", "1k", "100k"])
        ax.xaxis.set_minor_locator(NullLocator())
        ax.axhline(1.0, color="black", lw=1)
        ax.set_ylim(min([0.6] + ratios) - 0.05, max([1.2] + ratios) + 0.05)
        ax.set_ylabel("speed / Embree med.")
        ax.set_xlabel("wrong per million hostile", labelpad=2)
        ax.grid(alpha=0.4)
        handles = [Line2D([], [], ls="", marker=marker, ms=11, color=color)
                   for _, color, marker in PRICE_TRACERS.values()]
        fig.legend(handles, [label for label, _, _ in PRICE_TRACERS.values()], loc="upper center",
                   bbox_to_anchor=(0.5, page.y(fig, tile, 0.2)), ncol=2, frameon=False, handletextpad=0.2,
                   columnspacing=0.8)
    return _save(fig, path)


def chart_self_hits(results, path):
    """Lit pixels of a convex sphere falsely shadowed by their own shadow ray, against the scene's scale."""
    rows = results["self_hits"]["rows"]
    methods = list(dict.fromkeys(r["method"] for r in rows))
    fig = page.figure(1)
    page.title(fig, 0, "false self-shadows")
    ax = fig.add_axes(page.rect(fig, 0, 0.2, 0.42, 0.7, 0.44))
    colors = ["#ff7f0e", "#d62728", "#2ca02c"]
    for i, method in enumerate(methods):
        sel = [r for r in rows if r["method"] == method]
        ax.plot([r["scale"] for r in sel], [100 * r["fraction"] for r in sel], "o-", color=colors[i % 3], lw=3,
                label=method, zorder=3 + i)  # robust, at 0 everywhere, drawn over the others
    log_axis(ax, "x", [r["scale"] for r in rows], most=5)
    ax.set_xlabel("scene scale", labelpad=2)
    ax.set_ylabel("% of lit pixels")
    ax.grid(which="major", alpha=0.4)
    fig.legend(*ax.get_legend_handles_labels(), loc="upper center", bbox_to_anchor=(0.5, page.y(fig, 0, 0.2)),
               ncol=2, frameon=False, handlelength=1.4, columnspacing=0.8)
    return _save(fig, path)


def chart_animation(results, path):
    """Per frame of the animation: rebuild or refit time and the trace after each, and the SAH cost of
    both trees."""
    anim = results["animation"]
    rows = anim["rows"]
    frames = [r["frame"] for r in rows]
    ms = lambda key: [1e3 * r[key] for r in rows]  # noqa: E731
    fig = page.figure(2)
    page.title(fig, 0, "milliseconds per frame")
    times = fig.add_axes(page.rect(fig, 0, 0.17, 0.42, 0.79, 0.46))
    times.plot(frames, ms("rebuild_seconds"), "-", color="#1f77b4", lw=3, label="rebuild")
    times.plot(frames, ms("refit_seconds"), "-", color="#ff7f0e", lw=3, label="refit")
    times.plot(frames, ms("rebuilt_trace_seconds"), ":", color="#1f77b4", lw=3, label="trace, rebuilt")
    times.plot(frames, ms("refitted_trace_seconds"), ":", color="#ff7f0e", lw=3, label="trace, refitted")
    times.set_yscale("log")
    times.set_yticks([0.5, 1, 2, 5, 10, 20], ["0.5", "1", "2", "5", "10", "20"])
    times.yaxis.set_minor_locator(NullLocator())
    times.set_xlabel("frame", labelpad=2)
    times.grid(which="major", alpha=0.4)
    fig.legend(*times.get_legend_handles_labels(), loc="upper center", bbox_to_anchor=(0.5, page.y(fig, 0, 0.235)),
               ncol=2, frameon=False, handlelength=1.4, columnspacing=0.8)
    page.title(fig, 1, "tree quality: SAH cost")
    sah = fig.add_axes(page.rect(fig, 1, 0.17, 0.42, 0.79, 0.46))
    sah.plot(frames, [r["rebuilt_sah_cost"] for r in rows], "-", color="#1f77b4", lw=3, label="rebuilt")
    sah.plot(frames, [r["refitted_sah_cost"] for r in rows], "-", color="#ff7f0e", lw=3, label="refitted")
    sah.set_xlabel("frame", labelpad=2)
    sah.grid(alpha=0.4)
    fig.legend(*sah.get_legend_handles_labels(), loc="upper center", bbox_to_anchor=(0.5, page.y(fig, 1, 0.235)),
               ncol=2, frameon=False, handlelength=1.4, columnspacing=0.8)
    return _save(fig, path)


def _save(fig, path):
    page.save(fig, str(path))


def write_charts(results, out, only=None):
    """Draws the charts the results hold into `out`; `only`: these names alone. Returns their names."""
    charts = {"bench_throughput.png": chart_throughput, "bench_embree_ratio.png": chart_ratios,
              "bench_thesis.png": chart_thesis, "bench_leaks.png": chart_leaks, "bench_self_hits.png": chart_self_hits}
    if results["thesis"].get("image_error"):
        charts["bench_speed_accuracy.png"] = chart_speed_accuracy
    if results.get("animation"):
        charts["bench_animation.png"] = chart_animation
    if any(t.get("exactness") for m in results["meshes"].values() for t in m["tracers"]):
        charts["bench_price.png"] = chart_price
    for name, draw in charts.items():
        if only is None or name in only:
            draw(results, out / name)
    return sorted(name for name in charts if only is None or name in only)
