"""The public CI's workflow (.github/workflows/platforms.yml) against tools/platform_ci.py and ./raylab: it runs
only the script's steps, tests the Blender releases the script names with their Pythons, and its Linux job's
steps are the ones ./raylab test runs here."""
import pathlib
import re
import shlex
import sys

import pytest
import yaml  # python3-yaml, which ./raylab setup installs

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))
import platform_ci  # noqa: E402

WORKFLOW = yaml.safe_load((ROOT / ".github" / "workflows" / "platforms.yml").read_text())


def steps_of(job):
    """The platform_ci steps a job runs, in order, as (step, its arguments)."""
    found = []
    for step in WORKFLOW["jobs"][job]["steps"]:
        if "run" not in step:
            assert step["uses"].startswith("actions/"), step
            continue
        words = shlex.split(step["run"])
        assert words[1] == "tools/platform_ci.py", f"{job} runs something other than platform_ci: {step['run']}"
        found.append((words[2], words[3:]))
    return found


@pytest.mark.parametrize("job", sorted(WORKFLOW["jobs"]))
def test_every_step_of_the_workflow_is_a_step_of_platform_ci(job):
    steps = steps_of(job)
    assert steps and all(name in platform_ci.STEPS for name, _ in steps), steps
    assert [name for name, _ in steps][:3] == ["deps", "blender", "build"], "the build needs its Blender's Python"


def test_the_workflow_tests_the_blender_releases_and_pythons_platform_ci_names():
    matrix = WORKFLOW["jobs"]["blender"]["strategy"]["matrix"]
    assert matrix["blender"] == list(platform_ci.BLENDER_PYTHONS)
    pythons = {entry["blender"]: entry["python"] for entry in matrix["include"] if "blender" in entry}
    assert pythons == platform_ci.BLENDER_PYTHONS
    runners = {entry["platform"] for entry in matrix["include"] if "platform" in entry}
    assert runners == set(matrix["platform"]) == set(platform_ci.ARCHIVES)


def test_the_linux_jobs_steps_are_the_ones_raylab_test_runs_here():
    """What the Linux x64 job runs, ./raylab runs on this host: deps is ./raylab setup, the others are called
    by name (the download aside: here Debian's Blender stands in, `blender --local`)."""
    script = (ROOT / "raylab").read_text()
    called = set(re.findall(r'(?:"\$\{ci\[@\]\}"|tools/platform_ci\.py"?) ([a-z-]+)', script))
    linux = {name for name, _ in steps_of("blender")}
    assert linux - {"deps"} <= called, linux - called
    assert "blender --local blender" in script


LISTING = """<html><body><h1>Index of /release/Blender4.2/</h1><pre>
<a href="blender-4.2.0-linux-x64.tar.xz">blender-4.2.0-linux-x64.tar.xz</a>   16-Jul-2024 12:00  355M
<a href="blender-4.2.9-linux-x64.tar.xz">blender-4.2.9-linux-x64.tar.xz</a>   01-Apr-2025 12:00  355M
<a href="blender-4.2.10-linux-x64.tar.xz">blender-4.2.10-linux-x64.tar.xz</a> 01-May-2025 12:00  355M
<a href="blender-4.2.10-linux-x64.tar.xz.sha256">blender-4.2.10-linux-x64.tar.xz.sha256</a>
<a href="blender-4.2.10-windows-x64.zip">blender-4.2.10-windows-x64.zip</a>  01-May-2025 12:00  380M
<a href="blender-4.2.11-windows-x64.msi">blender-4.2.11-windows-x64.msi</a>  01-Jun-2025 12:00  380M
<a href="blender-4.2.10-macos-arm64.dmg">blender-4.2.10-macos-arm64.dmg</a>  01-May-2025 12:00  300M
</pre></body></html>"""


def test_the_newest_official_archive_of_a_release_is_picked_by_its_number_not_its_text():
    assert platform_ci.newest_archive(LISTING, "4.2", "linux-x64") == "blender-4.2.10-linux-x64.tar.xz"
    assert platform_ci.newest_archive(LISTING, "4.2", "windows-x64") == "blender-4.2.10-windows-x64.zip"
    assert platform_ci.newest_archive(LISTING, "4.2", "macos-arm64") == "blender-4.2.10-macos-arm64.dmg"
    with pytest.raises(SystemExit, match="no official Blender 4.5 for linux-x64"):
        platform_ci.newest_archive(LISTING, "4.5", "linux-x64")


def test_this_host_is_named_as_blender_names_it():
    assert platform_ci.this_platform() in {"linux-x64", "linux-arm64"}
