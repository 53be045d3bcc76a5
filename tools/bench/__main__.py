"""The entry point of ./raylab bench (python3 -m tools.bench): measures everything, or redraws and
publishes an earlier run's results."""
import argparse
import json
import os
import platform
import time
from pathlib import Path

from . import FULL, QUICK, ROOT, __doc__ as package_doc, log
from .charts import chart_animation, write_charts
from .experiments import (api_result, only_api, run_animation, run_api, run_builders, run_leaks, run_render,
                          run_self_hits, run_thesis)
from .report import animation_markdown, api_markdown, builders_markdown, markdown, publish, render_markdown
from .run import bench_binary, run_blender, run_native


# The experiments --only runs alone: how each is measured and how it is reported. `api` (alias `door`, its
# first part) runs raylab_bench first, for its rays and Embree's times.
ONLY = {"animation": (run_animation, animation_markdown), "builders": (run_builders, builders_markdown),
        "api": (only_api, api_markdown), "door": (only_api, api_markdown), "render": (run_render, render_markdown)}


def main():
    parser = argparse.ArgumentParser(prog="./raylab bench", description=package_doc.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a tiny configuration, well under a minute")
    parser.add_argument("--out", default=str(ROOT / "out" / "bench"))
    parser.add_argument("--build-dir", default=os.environ.get("RAYLAB_BUILD_DIR", str(ROOT / "build")))
    parser.add_argument("--no-blender", action="store_true", help="skip Blender's BVHTree")
    parser.add_argument("--replot", action="store_true",
                        help="redraw the charts and the table from <out>/results.json, measuring nothing")
    parser.add_argument("--only", choices=sorted(ONLY),
                        help="run one experiment alone: writes <out>/animation.json, .md and bench_animation.png, "
                             "or <out>/builders.json and .md, or <out>/api.json and .md (the user's path; door: "
                             "the same)")
    parser.add_argument("--baseline", metavar="CHECKOUT",
                        help="a checkout whose add-on holds its built module (last turn's main, say): F12's renderer "
                             "is measured against its renderer (--only render, or within the full run)")
    parser.add_argument("--publish", action="store_true",
                        help="copy the charts of a full run into the levels that show them (and the README)")
    args = parser.parse_args()
    out = Path(args.out)
    if args.replot or args.publish:
        results = json.loads((out / "results.json").read_text())
        if args.replot:
            results["charts"] = write_charts(results, out)
            (out / "results.json").write_text(json.dumps(results, indent=1))
            (out / "results.md").write_text(markdown(results))
        if args.publish:
            publish(results, out)
        return
    config = QUICK if args.quick else FULL
    if args.only:
        run, to_markdown = ONLY[args.only]
        out.mkdir(parents=True, exist_ok=True)
        if run is only_api:
            data = out / "data"
            data.mkdir(parents=True, exist_ok=True)
            result = run(config, bench_binary(args.build_dir), data)
        elif run is run_render:
            if not args.baseline:
                parser.error("--only render needs --baseline CHECKOUT")
            result = run(config, args.baseline)
        else:
            result = run(config)
        if args.only == "animation":
            chart_animation({"animation": result}, out / "bench_animation.png")
        (out / f"{args.only}.json").write_text(json.dumps(result, indent=1))
        report = "\n".join(to_markdown(result))
        (out / f"{args.only}.md").write_text(report)
        print(report)
        log(f"done: {out / (args.only + '.md')}")
        return
    data = out / "data"
    data.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()

    # The user's path: each mesh's API timing right after its own raylab_bench run, on its rays.
    api = {}
    native = run_native(config, bench_binary(args.build_dir), data,
                        after_each=lambda name, mesh: api.update({name: run_api(config, data, name, mesh)}))
    user_path = api_result(native, api)
    blender = {} if args.no_blender else run_blender(config, data, native)
    thesis = run_thesis(config)
    leaks = run_leaks(config, data)
    self_hits = run_self_hits(config)
    animation = run_animation(config)
    builders = run_builders(config)
    render = run_render(config, args.baseline) if args.baseline else None
    first = next(iter(native.values()))
    results = {"configuration": "quick" if args.quick else "full",
               "machine": {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                           "hardware_threads": first["hardware_threads"], "embree": first["embree_version"],
                           "platform": platform.platform()},
               "meshes": native, "blender": blender, "thesis": thesis, "leaks": leaks, "self_hits": self_hits,
               "animation": animation, "builders": builders, "api": user_path,
               "render": render}
    results["charts"] = write_charts(results, out)
    results["seconds_total"] = time.perf_counter() - started
    (out / "results.json").write_text(json.dumps(results, indent=1))
    (out / "results.md").write_text(markdown(results))
    print(markdown(results))
    log(f"done in {results['seconds_total']:.0f} s: {out / 'results.md'}")


if __name__ == "__main__":
    main()
