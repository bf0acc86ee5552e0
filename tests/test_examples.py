"""The examples run (at small sizes) and print what they promise, so they cannot rot."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).parents[1] / "examples"
ICUB = (
    Path(sys.prefix)
    / "lib"
    / f"python{sys.version_info.major}.{sys.version_info.minor}"
    / "site-packages/cmeel.prefix/share/example-robot-data/robots/icub_description/robots/icub.urdf"
)


def _run(name: str, *args: str) -> str:
    res = subprocess.run(
        [sys.executable, str(EXAMPLES / name), *args],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    return res.stdout


def test_paper_simulation_example():
    """The §3 study through the API prints rank, MAE and named combinations."""
    out = _run("op2_paper_simulation.py", "--count", "200", "--fresh", "500")
    assert "rank 42 of 63" in out and "first identifiable combinations" in out


def test_consistent_masses_example():
    """Consistent masses for a 3 %-heavier OP2; the URDF round trip is exact to 1e-12 m."""
    out = _run("op2_consistent_masses.py", "--seeds", "1", "--sizes", "38", "200", "--fresh", "500")
    err = float(out.split("fit CoP| = ")[1].split(" m")[0])
    assert "least squares" in out and err < 1e-12


def test_compare_methods_example():
    """The estimator comparison table prints, MAP beats least squares at n = 38."""
    out = _run("op2_compare_methods.py", "--seeds", "1", "--sizes", "38")
    ratio = float(out.split("MAP (evidence) / LS at n = 38: ")[1].split()[0])
    assert "| map, τ by evidence |" in out and ratio < 1


def test_pose_selection_example(tmp_path):
    """Pose selection prints the D-optimal vs random curve and writes the figure and poses."""
    out = _run("op2_pose_selection.py", str(tmp_path), "2000")
    assert "D-optimal" in out and (tmp_path / "pose_selection.png").stat().st_size > 1000
    assert (tmp_path / "poses.csv").is_file()


@pytest.mark.skipif(not ICUB.is_file(), reason="example-robot-data's iCub not installed")
def test_any_urdf_example_on_icub():
    """Any URDF: iCub from example-robot-data identifies from simulated CoPs."""
    out = _run("icub_any_urdf.py", str(ICUB), "r_sole", "--count", "400")
    assert "noise-free CoP RMSE on fresh poses" in out


def test_sensor_calibration_example():
    """Pad calibration on the bench prints the 2σ coverage of gains and offsets."""
    out = _run("op2_sensor_calibration.py", "--seeds", "1", "--candidates", "1500")
    assert "gains within 2σ of the truth" in out and "known sensors" in out
