"""F12 with raylab's cost passes and heat pass in a real Blender window (under Xvfb): the render runs on
Blender's job thread, and the Render Result it leaves holds the passes, their counts adding up to the
render's totals and the heat pass in raylab.heat_map's colours with its legend. Runs with
/usr/bin/python3 -m pytest tests/gui; writes out/gui/render_passes.png and .exr."""
import json
import os
import sys

import numpy as np
import pytest

import gui_util

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HERE = os.path.join(ROOT, "tests", "gui")
OUT = os.path.join(ROOT, "out", "gui")
sys.path.insert(0, os.path.join(ROOT, "addon"))
import raylab  # noqa: E402
from raylab import _raylab_images  # noqa: E402

HEAT_MAXIMUM = 100.0  # as render_passes_f12.py sets it


@pytest.fixture(scope="module")
def f12_passes():
    os.makedirs(OUT, exist_ok=True)
    blend = os.path.join(OUT, "demo_scene_passes.blend")
    report_path, exr, screenshot = (os.path.join(OUT, name) for name in
                                    ("render_passes.json", "render_passes.exr", "render_passes.png"))
    for path in (blend, report_path, exr, screenshot):
        if os.path.exists(path):
            os.remove(path)
    gui_util.demo_blend(blend)
    run = gui_util.run_watched(["xvfb-run", "-a", "-s", "-screen 0 1600x900x24", "blender", "--factory-startup", blend,
                          "--python-exit-code", "1", "--python", os.path.join(HERE, "render_passes_f12.py"), "--",
                          report_path, exr, screenshot], capture_output=True, text=True, timeout=300)
    assert os.path.exists(report_path), run.stdout[-3000:] + run.stderr[-3000:]
    with open(report_path) as file:
        report = json.load(file)
    assert not report["errors"], report["errors"]
    assert "can't modify blend data" not in run.stdout + run.stderr
    channels = _raylab_images.read_channels(exr)
    if tuple(report["blender"]) >= (5, 0):  # 5.x's EXR holds Combined alone: the passes as the engine filled them
        layer = report["view_layer"]
        for name, pixels in np.load(exr + ".npz").items():
            ids = "X" if pixels.shape[2] == 1 else "RGBA"
            for index, id_ in enumerate(ids):
                channels.setdefault(f"{layer}.{name}.{id_}", pixels[:, :, index])
    return report, channels


def test_the_job_thread_render_leaves_every_cost_pass_adding_up_to_its_totals(f12_passes):
    report, channels = f12_passes
    record, layer = report["last_render"], report["view_layer"]
    for name, info in raylab.COST_PASS_INFO.items():
        values = channels[f"{layer}.{name}.X"]
        assert values.sum(dtype=np.float64) == record[info["counter"]], name
    assert record["rays"] > record["rays_primary"]


def test_the_heat_pass_is_the_triangle_tests_in_heat_map_colours_with_the_legend(f12_passes):
    report, channels = f12_passes
    layer = report["view_layer"]
    heat = np.stack([channels[f"{layer}.raylab Heat.{c}"] for c in "RGBA"], axis=-1)
    triangles = next(n for n, i in raylab.COST_PASS_INFO.items() if i["counter"] == "triangle_tests")
    legend = raylab.heat_legend(HEAT_MAXIMUM, width=heat.shape[1])
    expected = raylab.heat_map(channels[f"{layer}.{triangles}.X"], HEAT_MAXIMUM)
    assert np.array_equal(heat[:-len(legend)], expected[:-len(legend)])
    assert np.array_equal(heat[-len(legend):], legend)
    scale = raylab.heat_scale_text("Triangle tests", HEAT_MAXIMUM)
    assert report["last_render"]["heat_scale"] == scale
