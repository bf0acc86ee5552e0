"""The walk-through's figures (docs/walkthrough.md) are those of a verbatim run
(tools/readme_numbers.py)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.slow
def test_readme_quotes_a_verbatim_run():
    """Every figure the walk-through section quotes, at its printed precision, is what the
    commands give now."""
    spec = importlib.util.spec_from_file_location(
        "readme_numbers", ROOT / "tools/readme_numbers.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    readme = (ROOT / "docs" / "walkthrough.md").read_text()
    section = readme
    for line in mod.COMMANDS:
        assert line.replace(" --truth", "\n    --truth") in section or line in section, line
    figures = mod.walk_through()
    figures.pop("seconds")
    missing = {k: v for k, v in figures.items() if v not in section}
    assert not missing, f"docs/walkthrough.md quotes other figures than a run gives: {missing}"


@pytest.mark.slow
def test_readme_quotes_the_physics_bench_run():
    """The walk-through's physics-bench rows and figures are what `--engine mujoco` gives now."""
    pytest.importorskip("mujoco")
    spec = importlib.util.spec_from_file_location(
        "readme_numbers", ROOT / "tools/readme_numbers.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    readme = (ROOT / "docs" / "walkthrough.md").read_text()
    section = readme
    m = mod.walk_through("mujoco")
    quoted = [
        "manufacturer mean",
        "manufacturer RMS",
        "identified mean",
        "identified RMS",
        "truth identified",
        "truth manufacturer",
        "fresh identified",
        "fresh manufacturer",
        "pads − gravity-aware statics max",
        "pads − flat statics max",
        "pads − flat statics RMS",
        "foot tilt max",
        "servo sag max",
    ]
    missing = {k: m[k] for k in quoted if m[k] not in section}
    assert not missing, f"docs/walkthrough.md quotes other figures than a run gives: {missing}"
    assert f"{m['skipped']} of the 38 poses topple" in section


@pytest.mark.slow
def test_the_torques_walkthrough_quotes_a_run_of_its_block():
    """docs/torques.md's walk-through figures are what its own commands give now
    (tools/torques_walkthrough.py --check runs the page's block)."""
    import subprocess
    import sys

    pytest.importorskip("mujoco")
    tool = ROOT / "tools" / "torques_walkthrough.py"
    res = subprocess.run([sys.executable, str(tool), "--check"], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr
