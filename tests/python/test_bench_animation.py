"""`python -m tools.bench --only animation --quick`: the refit experiment runs alone and writes its chart,
its table and a row per frame whose refitted and rebuilt hits agree. No timing is asserted."""
import json
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_animation_experiment_runs_alone(tmp_path):
    subprocess.run([sys.executable, "-m", "tools.bench", "--only", "animation", "--quick", "--out", str(tmp_path)],
                   cwd=ROOT, check=True, timeout=600, stdout=subprocess.DEVNULL)
    results = json.loads((tmp_path / "animation.json").read_text())
    assert len(results["rows"]) == results["frames"] > 1
    for row in results["rows"]:
        assert row["same_hits"], row["frame"]
        assert row["rebuild_seconds"] > 0 and row["refit_seconds"] > 0
        assert row["rebuilt_sah_cost"] > 0 and row["refitted_sah_cost"] > 0
    first = results["rows"][0]
    assert first["rebuilt_sah_cost"] == first["refitted_sah_cost"]  # frame 0 is the same build
    assert results["summary"]["all_hits_equal"]
    chart = (tmp_path / "bench_animation.png").read_bytes()
    assert chart[:8] == b"\x89PNG\r\n\x1a\n" and len(chart) > 10_000
    assert (tmp_path / "animation.md").read_text().startswith("## An animation")
