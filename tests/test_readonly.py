"""A read-only install (package folder, $HOME and NUMBA_CACHE_DIR not writable) still runs."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import sescid

SCRIPT = """
import numpy as np, sescid
robot = sescid.load_robot("op2")
print(float(robot.cop(np.zeros((1, robot.nq)))[0, 0]))
"""


def _blocked_copy(tmp_path: Path) -> Path:
    """The package copied so that no cache folder can be created anywhere: a *file* named
    ``__pycache__`` in every package folder (works for root too, unlike chmod)."""
    site = tmp_path / "site"
    shutil.copytree(
        Path(sescid.__file__).parent, site / "sescid", ignore=shutil.ignore_patterns("__pycache__")
    )
    launcher = Path(sescid.__file__).parents[1] / "_sescid_launch.py"  # the script's entry
    shutil.copy(launcher, site / launcher.name)
    for folder in [site / "sescid", *(p for p in (site / "sescid").rglob("*") if p.is_dir())]:
        (folder / "__pycache__").write_text("not a folder\n")
    return site


@pytest.mark.slow
def test_kernels_compile_in_memory_when_no_cache_is_writable(tmp_path):
    """`robot.cop` and `sescid --version` work with no writable cache (numba compiles in
    memory) and print nothing on stderr; the CoP equals the normal install's."""
    site = _blocked_copy(tmp_path)
    env = dict(os.environ)
    env |= {
        "PYTHONPATH": str(site),
        "HOME": "/dev/null",
        "XDG_CACHE_HOME": "/dev/null/cache",
        "NUMBA_CACHE_DIR": "/dev/null/numba",
    }
    res = subprocess.run(
        [sys.executable, "-c", SCRIPT], env=env, cwd=tmp_path, capture_output=True, text=True
    )
    assert res.returncode == 0 and res.stderr == "", res.stderr
    import numpy as np

    expected = float(sescid.load_robot("op2").cop(np.zeros((1, 20)))[0, 0])
    assert float(res.stdout) == expected
    version = subprocess.run(
        [sys.executable, "-c", "from _sescid_launch import main; main()", "--version"],
        env=env,
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert version.returncode == 0 and "version" in version.stdout, version.stderr
