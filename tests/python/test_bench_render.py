"""`python -m tools.bench --only render --quick --baseline CHECKOUT`: F12's renderer against another
checkout's, each render in its own process. Here the baseline is this checkout itself, so the run checks
the experiment's plumbing (both sides render, every row has its medians); no timing is asserted."""
import json
import pathlib
import subprocess
import sys

from tools.bench import QUICK

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_render_experiment_runs_against_a_baseline(tmp_path):
    subprocess.run([sys.executable, "-m", "tools.bench", "--only", "render", "--quick", "--baseline", str(ROOT),
                    "--out", str(tmp_path)], cwd=ROOT, check=True, timeout=300, stdout=subprocess.DEVNULL)
    result = json.loads((tmp_path / "render.json").read_text())
    assert result["baseline"] == str(ROOT)
    expected = {(name, ss) for name, _, _, levels, _ in QUICK["render"]["scenes"] for ss in levels}
    assert {(r["scene"], r["super_sampling"]) for r in result["rows"]} == expected
    for row in result["rows"]:
        assert row["triangles"] > 0
        for clock in ("render_seconds", "cpu_seconds"):
            assert row[f"baseline_{clock}_median"] > 0 and row[f"this_{clock}_median"] > 0
            assert row[f"speedup_{clock}"] > 0
    assert (tmp_path / "render.md").read_text().startswith("## F12's renderer against the baseline's")


def test_render_needs_a_baseline(tmp_path):
    done = subprocess.run([sys.executable, "-m", "tools.bench", "--only", "render", "--quick", "--out", str(tmp_path)],
                          cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "--baseline" in done.stderr
