"""`python -m tools.bench --only builders --quick`: the builders' experiment runs alone and writes a row
per mesh and builder whose hits agree with the default builder's. No timing is asserted."""
import json
import pathlib
import subprocess
import sys

import raylab

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_builders_experiment_runs_alone(tmp_path):
    subprocess.run([sys.executable, "-m", "tools.bench", "--only", "builders", "--quick", "--out", str(tmp_path)],
                   cwd=ROOT, check=True, timeout=600, stdout=subprocess.DEVNULL)
    results = json.loads((tmp_path / "builders.json").read_text())
    assert [r["builder"] for r in results["rows"]][:len(raylab.BUILDERS)] == list(raylab.BUILDERS)
    for row in results["rows"]:
        assert row["camera_same_hits"] and row["random_same_hits"], row["builder"]
        assert row["build_seconds"] > 0 and row["sah_cost"] > 0 and row["nodes"] > 0
        assert row["camera_nodes_per_ray"] > 0 and row["random_triangle_tests_per_ray"] > 0
    assert (tmp_path / "builders.md").read_text().startswith("## The BVH's builders")
