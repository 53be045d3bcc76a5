"""./raylab demo: render the goat-head scene with every structure at super sampling 1, 2 and 3.

Runs inside headless Blender (`blender -b --factory-startup --python tools/demo.py -- [options]`). Prints
the measurements in the form of the VRT thesis's tables 1-4 (render seconds, and ray-triangle tests, per
structure per super-sampling level) and writes the images, a Markdown table and a JSON file to out/demo/.
"""
import argparse
import json
import os
import sys

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "addon"))

import raylab  # noqa: E402
from raylab.blender import compare, default_scene, heat_maps, levels, scene_export  # noqa: E402

SUPER_SAMPLING = (1, 2, 3)
# The demo's heat maps are drawn on the scale of the level that teaches them, so that they compare.
HEAT_MAPS_LEVEL = "where_work_goes"
# VRT's averages on its goat-head scene (thesis section 6.1, tables 1-4), for comparison.
VRT_SECONDS = {1: (0.1803, 0.1480, 0.2784), 2: (0.5674, 0.4708, 0.8902), 3: (1.2525, 0.9915, 1.9080)}
VRT_TRIANGLE_TESTS = {1: (116_960_000, 22_994_336, 1_173_277), 2: (467_840_000, 92_273_399, 4_700_384),
                      3: (1_052_630_000, 207_390_548, 10_557_042)}


def parse_arguments():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    parser = argparse.ArgumentParser(prog="./raylab demo", description=__doc__.splitlines()[0])
    # 160 x 120 pixels: about the 20,000 camera rays of VRT's trials (116,960,000 tests / 5,848 triangles).
    parser.add_argument("--resolution", default="160x120", help="image size WxH (default 160x120)")
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "demo"), help="output folder")
    arguments = parser.parse_args(argv)
    try:
        width, height = (int(n) for n in arguments.resolution.lower().split("x"))
    except ValueError:
        parser.error(f"--resolution must look like 160x120, not {arguments.resolution!r}")
    return (width, height), arguments.out


def markdown_table(title, header, rows):
    lines = [f"**{title}**", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def decrease(value, reference):
    return f"{100.0 * (1.0 - value / reference):.2f} %" if reference else "-"


def tables(measurements, width, height, triangle_count):
    """The Markdown tables: seconds and triangle tests per structure (columns) per super sampling (rows)."""
    structures = list(raylab.STRUCTURES)
    scene_note = f"goat head ({triangle_count} triangles with the ground), {width} x {height} px"
    seconds = [[f"Super Sampling {ss}"] + [f"{measurements[ss][s]['render_seconds']:.4f}" for s in structures]
               + [" / ".join(f"{t:.4f}" for t in VRT_SECONDS[ss])] for ss in SUPER_SAMPLING]
    builds = [[f"Super Sampling {ss}"] + [f"{1000 * measurements[ss][s]['build_seconds']:.2f}" for s in structures]
              for ss in SUPER_SAMPLING]
    tests = [[f"Super Sampling {ss}"] + [f"{measurements[ss][s]['triangle_tests']:,}" for s in structures]
             + [" / ".join(f"{t:,}" for t in VRT_TRIANGLE_TESTS[ss])] for ss in SUPER_SAMPLING]
    saved = [[f"Super Sampling {ss}"] + [decrease(measurements[ss][s]["triangle_tests"],
                                                  measurements[ss]["none"]["triangle_tests"])
                                         for s in structures[1:]] for ss in SUPER_SAMPLING]
    rays = [[f"Super Sampling {ss}"] + [f"{measurements[ss]['bvh'][k]:,}" for k in
                                        ("rays_primary", "rays_shadow", "rays_reflection", "rays_refraction")]
            + [f"{measurements[ss][s]['rays_ignored']:,}" for s in ("aabb", "octree")] for ss in SUPER_SAMPLING]
    vrt = "VRT (no acceleration / AABB / octree)"
    return "\n".join([
        markdown_table(f"Tables 1-3: render seconds ({scene_note})", ["", *structures, vrt], seconds),
        markdown_table("Build milliseconds (all meshes of the scene)", ["", *structures], builds),
        markdown_table("Table 4: ray-triangle intersection tests", ["", *structures, vrt], tests),
        markdown_table("Decrease in ray-triangle tests against no acceleration", ["", *structures[1:]], saved),
        markdown_table("Rays traced (the same for every structure) and rays ignored by a box",
                       ["", "primary", "shadow", "reflection", "refraction", "ignored (aabb)",
                        "ignored (octree)"], rays),
    ])


def heat_map_measurements(scene, out):
    """Render Heat Maps on the demo scene (every structure's triangle tests per camera ray, one scale):
    writes heat_maps.png (the maps left to right in STRUCTURES' order, the legend under them) and returns
    the record (hardest pixel, where, mean, total per structure)."""
    settings = levels.find_level(HEAT_MAPS_LEVEL).settings["raylab_render"]
    scene.raylab_render.heat_maps_scale = settings["heat_maps_scale"]
    job = heat_maps.new_job(bpy.context, time_limit=0.0)
    job.run()
    if job.error is not None:
        raise job.error
    record = heat_maps.heat_record(job.results, job.render_size, scene.raylab_render.heat_maps_scale)
    picture = heat_maps.heat_image(job.results, record["maximum"])
    height = record["size"][1]  # without the band Blender's Image Editor writes the numbers in: they are in the table
    raylab.write_image(os.path.join(out, "heat_maps.png"),
                       np.concatenate([picture[:height], picture[height + heat_maps.NUMBER_BAND:]]))
    return record


def heat_maps_table(record):
    rows = [[name, f"{s['hardest']:,}", "{}, {}".format(*s["probe_pixel"]), f"{s['mean']:,.1f}", f"{s['total']:,.0f}"]
            for name, s in record["structures"].items()]
    w, h = record["size"]
    return "\n" + markdown_table(
        f"Heat maps ({w} x {h}, one camera ray per pixel): {record['label'].lower()} per pixel, "
        f"scale 0 to {record['maximum']:g}+ (heat_maps.png)",
        ["structure", "hardest pixel", "at (x, y)", "mean per pixel", "total"], rows)


def main():
    (width, height), out = parse_arguments()
    os.makedirs(out, exist_ok=True)
    raylab.register()
    scene = bpy.context.scene
    default_scene.build_default_scene(scene, resolution=(width, height))
    scene.render.engine = 'RAYLAB'
    exported = scene_export.export_scene(bpy.context.evaluated_depsgraph_get())
    triangle_count = sum(len(triangles) for _, triangles in exported.meshes)
    measurements = {}
    for ss in SUPER_SAMPLING:
        measurements[ss] = {}
        for result in compare.compare_structures(exported, scene.raylab_render, super_sampling=ss):
            structure = result.structure
            raylab.write_image(os.path.join(out, f"goathead_{structure}_ss{ss}.png"), result.image)
            measurements[ss][structure] = {key: (value.item() if hasattr(value, "item") else value)
                                           for key, value in result.stats.items()}
            print(f"  rendered {structure:6} at super sampling {ss}: "
                  f"{measurements[ss][structure]['render_seconds']:.3f} s", flush=True)
    heat = heat_map_measurements(scene, out)
    text = tables(measurements, width, height, triangle_count) + heat_maps_table(heat)
    print("\n" + text)
    with open(os.path.join(out, "table.md"), "w") as file:
        file.write(text)
    with open(os.path.join(out, "results.json"), "w") as file:
        json.dump({"scene": "goat head", "width": width, "height": height, "triangles": triangle_count,
                   "measurements": {str(ss): m for ss, m in measurements.items()}, "heat_maps": heat},
                  file, indent=2)
    print(f"raylab demo: images, table.md and results.json in {out}")


main()
