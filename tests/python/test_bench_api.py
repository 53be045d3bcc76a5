"""`python -m tools.bench --only api --quick`: the user's path (`import raylab`, Structure and Scene, both
contracts) on raylab_bench's own rays, beside Embree's single rays and packets, and the goal table. No
timing is asserted: only that every call was measured against every reference and reported."""
import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import raylab
from tools.bench import QUICK
from tools.bench.experiments import API_QUERIES, API_SETS, MISSING

ROOT = pathlib.Path(__file__).resolve().parents[2]
BUILD = pathlib.Path(os.environ.get("RAYLAB_BUILD_DIR", ROOT / "build"))

pytestmark = pytest.mark.skipif(not (BUILD / "raylab_bench").exists(),
                                reason="raylab_bench is built only when Embree (libembree-dev) is found")


@pytest.fixture(scope="module")
def api(tmp_path_factory):
    out = tmp_path_factory.mktemp("api")
    subprocess.run([sys.executable, "-m", "tools.bench", "--only", "api", "--quick", "--out", str(out),
                    "--build-dir", str(BUILD)], cwd=ROOT, check=True, timeout=300, stdout=subprocess.DEVNULL)
    return out, json.loads((out / "api.json").read_text())


def test_every_call_is_measured_against_every_reference(api):
    _, result = api
    assert list(result["meshes"]) == [name for name, _ in QUICK["meshes"]]
    for name, mesh in result["meshes"].items():
        rows = {(r["target"], r["contract"], r["rays"], r["query"]): r for r in mesh["rows"]}
        assert set(rows) == {(t, c, s, q) for t in ("Structure", "Scene") for c in raylab.CONTRACTS
                             for s in API_SETS + (MISSING,) for q, _ in API_QUERIES}
        for (_, _, ray_set, _), r in rows.items():
            assert r["rays_per_second"] > 0 and r["ns_per_ray"] > 0
            if ray_set == MISSING:
                assert r["hit_share"] == 0.0  # every ray misses the root box
            else:
                assert all(r[f"ratio_to_{k}"] > 0 for k in ("embree_1", "embree_8", "core")), r
        # the framing camera hits more than the one with sky around the mesh
        assert rows[("Structure", "exact", "camera", "intersect")]["hit_share"] > \
            rows[("Structure", "exact", "camera_sky", "intersect")]["hit_share"] > 0
        exactness = result["exactness"][name]
        assert exactness["exact_wrong"] == 0 and exactness["unexplained"] == 0
        assert exactness["embree_packets_differ_from_single"] == 0  # no hostile rays in this run


def test_the_api_traces_the_rays_raylab_bench_traced(api):
    """The rays the API traced are every ray of raylab_bench's sets (its cameras at the configured size),
    as raylab_bench's own rows (origin, tmin, direction, tmax)."""
    out, _ = api
    name = QUICK["meshes"][0][0]
    native = json.loads((out / "data" / f"{name}.json").read_text())
    width, height = native["camera"]["width"], native["camera"]["height"]
    for ray_set in API_SETS:
        rows = np.load(out / "data" / f"{name}.trace_{ray_set}.npy")
        assert rows.dtype == np.float32 and rows.shape == (native["ray_sets"][ray_set]["count"], 8)
        if ray_set.startswith("camera"):
            assert len(rows) == width * height


def test_the_goal_table_is_written(api):
    out, _ = api
    report = (out / "api.md").read_text()
    assert report.startswith("## The user's path: `import raylab` against Embree")
    for goal in ("fixed cost per ray, rays missing the root (ns)", "exact, camera with sky / Embree packets",
                 "fast, random / Embree single rays", "exact: wrong answers per million"):
        assert f"| {goal}" in report, goal


def test_embree_packets_equal_its_single_rays_on_a_small_mesh(tmp_path):
    """raylab_bench's packet tracer (rtcIntersect8 / rtcOccluded8 over runs of 8, the last one partial)
    against rtcIntersect1 / rtcOccluded1 on the same scene, camera, shadow and random rays of an
    icosphere: the same answers, bit for bit. The camera's 851 rays and the 1,003 random ones end in a
    partial packet."""
    subprocess.run([str(BUILD / "raylab_bench"), "--mesh", "icosphere:3", "--name", "ico", "--out", str(tmp_path),
                    "--camera", "37x23", "--random-rays", "1003", "--hostile-rays", "0", "--export-rays", "10",
                    "--reps", "1", "--build-reps", "1", "--rep-seconds", "0.001", "--threads", "1",
                    "--structures", "bvh", "--contracts", "exact", "--embree", "medium"],
                   check=True, timeout=120, stderr=subprocess.DEVNULL)
    mesh = json.loads((tmp_path / "ico.json").read_text())
    packets = {t["name"]: t for t in mesh["tracers"]}["embree_packets"]
    assert tuple(packets["tracing"]["per_ray_set"]) == ("camera", "camera_sky", "shadow", "random")
    for ray_set, per in packets["tracing"]["per_ray_set"].items():
        a = per["agreement_with_single_rays"]
        assert a["rays"] == mesh["ray_sets"][ray_set]["count"]
        assert a["closest"]["same"] == a["any"]["same"] == a["rays"], (ray_set, a)
