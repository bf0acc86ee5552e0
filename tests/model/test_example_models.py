"""The example models ship with the package and load by name from any folder."""

from __future__ import annotations

import fnmatch
import tomllib
from pathlib import Path

import pytest

import sescid
from sescid.errors import ModelError
from sescid.robots import EXAMPLES, example_path, model_file_of

ROOT = Path(__file__).resolve().parents[2]


def test_an_example_loads_by_name_from_another_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    robot = sescid.load_robot("wheeled_humanoid", "axle", line="y")
    assert robot.model_path == example_path("wheeled_humanoid")
    assert robot.total_mass == pytest.approx(11.6, abs=0.05)
    assert model_file_of("wheeled_humanoid") == EXAMPLES["wheeled_humanoid"]
    assert model_file_of("op2") is not None and model_file_of("model.urdf") is None


def test_an_unknown_name_lists_the_examples():
    with pytest.raises(ModelError, match="wheeled_humanoid"):
        sescid.load_robot("no_such_robot")
    with pytest.raises(ModelError, match="unknown example model"):
        example_path("op2")


def test_every_file_of_the_robots_folder_is_package_data():
    """pyproject's package-data patterns cover every model and data file under robots/ (a
    plain install has them)."""
    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())
    patterns = cfg["tool"]["setuptools"]["package-data"]["sescid"]
    pkg = ROOT / "src" / "sescid"
    files = [p.relative_to(pkg).as_posix() for p in (pkg / "robots").rglob("*")
             if p.is_file() and p.suffix not in (".py", ".pyc")]  # fmt: skip
    assert set(EXAMPLES.values()) <= {pkg / f for f in files}
    assert [f for f in files if not any(fnmatch.fnmatch(f, p) for p in patterns)] == []
