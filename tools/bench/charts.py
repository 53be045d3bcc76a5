"""The benchmark's charts (bench_*.png, matplotlib without a display)."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import raylab  # noqa: E402

from .experiments import THESIS, thesis_structures  # noqa: E402
from .run import run_lookup  # noqa: E402


def legend_below(fig, ax, columns):
    """One legend for the whole figure, under the plots, where it hides no bar or line."""
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=columns, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.09, 1, 1))


def chart_throughput(results, path):
    meshes = list(results["meshes"])
    names = list(raylab.STRUCTURES) + ["embree_medium", "embree_high"]
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.2))
    for ax, ray_set in zip(axes, ("camera", "random")):
        width = 0.8 / (len(names) + 1)
        for i, tracer in enumerate(names):
            values = []
            for m in meshes:
                t = {x["name"]: x for x in results["meshes"][m]["tracers"]}.get(tracer)
                run = run_lookup(t, ray_set, "closest", 2) if t and not t["error"] else None
                values.append(run["rays_per_second"] if run else 0)
            ax.bar(np.arange(len(meshes)) + i * width, values, width, label=tracer.replace("_", " "))
        blender = [results["blender"].get("meshes", {}).get(m, {}).get("ray_sets", {}).get(ray_set, {})
                   .get("rays_per_second", 0) for m in meshes]
        ax.bar(np.arange(len(meshes)) + len(names) * width, blender, width, label="Blender BVHTree (1 thread)",
               color="0.5")
        ax.set_yscale("log")
        ax.set_xticks(np.arange(len(meshes)) + 0.4 - width / 2)
        ax.set_xticklabels([f"{m}\n{results['meshes'][m]['triangles']:,} tris" for m in meshes])
        ax.set_ylabel("closest-hit rays per second (2 threads)")
        ax.set_title(f"{ray_set} rays: closest hit throughput")
        ax.grid(axis="y", which="both", alpha=0.3)
    legend_below(fig, axes[1], len(names) + 1)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def chart_ratios(results, path):
    meshes = list(results["meshes"])
    keys = [("camera_closest_2t_rays_per_second", "camera closest rays/s"),
            ("camera_any_2t_rays_per_second", "camera any-hit rays/s"),
            ("random_closest_2t_rays_per_second", "random closest rays/s"),
            ("random_any_2t_rays_per_second", "random any-hit rays/s"),
            ("build_2t_seconds", "build seconds"), ("memory_bytes", "memory bytes")]
    fig, ax = plt.subplots(figsize=(11, 4.9))
    width = 0.8 / len(keys)
    for i, (key, label) in enumerate(keys):
        values = []
        for m in meshes:
            bvh = {x["name"]: x for x in results["meshes"][m]["tracers"]}["bvh"]
            values.append(bvh.get("ratios_to_embree_medium", {}).get(key, 0))
        ax.bar(np.arange(len(meshes)) + i * width, values, width, label=label)
    ax.axhline(1.0, color="k", lw=1)
    ax.set_xticks(np.arange(len(meshes)) + 0.4 - width / 2)
    ax.set_xticklabels(meshes)
    embree = f"Embree {results['machine']['embree']}"
    ax.set_ylabel(f"raylab BVH / {embree} (ratio)")
    ax.set_title(f"raylab BVH against {embree} on the same rays, 2 threads (1 = equal; rays/s above 1 is faster, "
                 "seconds and bytes above 1 are worse)", fontsize=9)
    ax.grid(axis="y", alpha=0.3)
    legend_below(fig, ax, len(keys))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def chart_thesis(results, path):
    th = results["thesis"]
    levels = sorted({r["super_sampling"] for r in th["rows"]})
    by = {(r["structure"], r["super_sampling"]): r for r in th["rows"]}
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.0))
    for s in thesis_structures(th):
        axes[0].plot(levels, [by[(s, ss)]["render_seconds_median"] for ss in levels], "o-", label=f"raylab {s}")
        axes[1].plot(levels, [by[(s, ss)]["triangle_tests"] for ss in levels], "o-", label=f"raylab {s}")
    for s in ("none", "aabb", "octree"):
        axes[0].plot([1, 2, 3], THESIS["render_seconds"][s], "x--", label=f"VRT thesis {s}")
        axes[1].plot([1, 2, 3], THESIS["triangle_tests"][s], "x--", label=f"VRT thesis {s}")
    axes[0].set_ylabel("render time (s, median)")
    axes[1].set_ylabel("ray-triangle tests")
    for ax in axes:
        ax.set_yscale("log")
        ax.set_xlabel("super-sampling N (NxN samples per pixel)")
        ax.set_xticks(levels)
        ax.grid(which="both", alpha=0.3)
    axes[0].set_title(f"Goat head render time (raylab.render, {th['width']}x{th['height']}) vs the VRT thesis")
    axes[1].set_title("Ray-triangle tests vs the VRT thesis (Table 4)")
    legend_below(fig, axes[0], 7)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def chart_speed_accuracy(results, path):
    th = results["thesis"]
    by = {(r["structure"], r["super_sampling"]): r for r in th["rows"]}
    fig, ax = plt.subplots(figsize=(8, 5))
    for s in thesis_structures(th):
        points = [(by[(e["structure"], e["super_sampling"])]["render_seconds_median"], e["psnr_db"], e["super_sampling"])
                  for e in th["image_error"] if e["structure"] == s and e["psnr_db"] is not None]
        if not points:
            continue
        ax.plot([p[0] for p in points], [p[1] for p in points], "o-", label=s)
        for x, y, ss in points:
            ax.annotate(f"{ss}x{ss}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.set_xscale("log")
    ax.set_xlabel("render time (s, median)")
    ax.set_ylabel(f"PSNR against the {th['reference_super_sampling']}x{th['reference_super_sampling']} "
                  "super-sampled render (dB)")
    ax.set_title("Speed against accuracy: the same images, at each structure's cost")
    ax.grid(which="both", alpha=0.3)
    ax.legend(title="structure")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def chart_leaks(results, path):
    rows = results["leaks"]
    labels = list(dict.fromkeys(f"{r['mesh']}\n{r['rays']}" for r in rows))
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for i, test in enumerate(raylab.TRIANGLE_TESTS):
        sel = {f"{r['mesh']}\n{r['rays']}": r for r in rows if r["triangle_test"] == test}
        x = np.arange(len(labels)) + i * 0.4
        axes[0].bar(x, [100 * sel[l]["escaped"] / sel[l]["ray_count"] for l in labels], 0.4, label=test)
        axes[1].bar(x, [sel[l]["rays_per_second"] / 1e6 for l in labels], 0.4, label=test)
    axes[0].set_ylabel("rays escaping the closed mesh (%)")
    axes[0].set_title("Rays from inside a closed mesh that escape (must be 0)")
    axes[1].set_ylabel("closest-hit rays per second, millions (BVH, all threads)")
    axes[1].set_title("Throughput of each triangle test on the same rays")
    for ax in axes:
        ax.set_xticks(np.arange(len(labels)) + 0.2)
        ax.set_xticklabels(labels, fontsize=7)
        ax.legend()
        ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def chart_self_hits(results, path):
    rows = results["self_hits"]["rows"]
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for method in dict.fromkeys(r["method"] for r in rows):
        sel = [r for r in rows if r["method"] == method]
        ax.plot([r["scale"] for r in sel], [100 * r["fraction"] for r in sel], "o-", label=method)
    ax.set_xscale("log")
    ax.set_xlabel("scene scale (object size and distance from the origin, scene units)")
    ax.set_ylabel("lit pixels falsely self-shadowed (%)")
    ax.set_title("Shadow acne against scene scale: fixed epsilon vs the robust ulp offset")
    ax.grid(which="both", alpha=0.3)
    ax.legend(title="secondary-ray origin")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def chart_animation(results, path):
    """Per frame of the animation: build or refit time against trace time, and the SAH cost of both trees."""
    anim = results["animation"]
    rows = anim["rows"]
    frames = [r["frame"] for r in rows]
    ms = lambda key: [1e3 * r[key] for r in rows]  # noqa: E731
    fig, (times, sah) = plt.subplots(1, 2, figsize=(11, 4.5))
    times.plot(frames, ms("rebuild_seconds"), "o-", color="C0", ms=3, label="rebuild")
    times.plot(frames, ms("refit_seconds"), "o-", color="C1", ms=3, label="refit")
    times.plot(frames, ms("rebuilt_trace_seconds"), "--", color="C0", label="trace after rebuild")
    times.plot(frames, ms("refitted_trace_seconds"), "--", color="C1", label="trace after refit")
    times.set_yscale("log")
    times.set_xlabel("frame")
    times.set_ylabel("milliseconds (median)")
    times.set_title(f"{anim['mesh']} ({anim['triangles']:,} triangles), {anim['rays']:,} rays on one thread",
                    fontsize=9)
    times.grid(which="both", alpha=0.3)
    times.legend(fontsize=8)
    sah.plot(frames, [r["rebuilt_sah_cost"] for r in rows], "o-", color="C0", ms=3, label="rebuilt BVH")
    sah.plot(frames, [r["refitted_sah_cost"] for r in rows], "o-", color="C1", ms=3, label="refitted BVH")
    sah.set_xlabel("frame")
    sah.set_ylabel("SAH cost (normalised by the root's area)")
    sah.set_title("Tree quality: the refitted tree degrades as the mesh moves away from frame 0", fontsize=9)
    sah.grid(alpha=0.3)
    sah.legend(fontsize=8)
    fig.suptitle("An animation (twist and wave): refit the BVH or rebuild it every frame")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_charts(results, out):
    charts = {"bench_throughput.png": chart_throughput, "bench_embree_ratio.png": chart_ratios,
              "bench_thesis.png": chart_thesis, "bench_leaks.png": chart_leaks, "bench_self_hits.png": chart_self_hits}
    if results["thesis"].get("image_error"):
        charts["bench_speed_accuracy.png"] = chart_speed_accuracy
    if results.get("animation"):
        charts["bench_animation.png"] = chart_animation
    for name, draw in charts.items():
        draw(results, out / name)
    return sorted(charts)
