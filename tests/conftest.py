"""Shared fixtures: the embedded OP2, a public humanoid URDF, the Pinocchio oracle."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

import sescid

# One BLAS thread: the tests' matrices are small, and a thread pool per process only
# oversubscribes the cores when pytest or other jobs run beside it.
threadpool_limits(1)
# A bug in a command shows its traceback in the tests (users get one line: cli.common)
os.environ.setdefault("SESCID_TRACEBACK", "1")


@pytest.fixture(scope="session")
def op2():
    return sescid.load_robot("op2")


@pytest.fixture(scope="session")
def robot(op2):
    """The embedded OP2 (the default robot of most tests)."""
    return op2


@pytest.fixture(scope="session")
def icub_path() -> Path:
    """iCub's URDF as shipped by the example-robot-data package (a public humanoid)."""
    import cmeel

    base = Path(cmeel.__file__).resolve().parent.parent / "cmeel.prefix" / "share"
    path = base / "example-robot-data" / "robots" / "icub_description" / "robots" / "icub.urdf"
    if not path.is_file():  # other cmeel layouts: search the prefix
        found = list(Path(sys.prefix).rglob("icub_description/robots/icub.urdf"))
        assert found, "example-robot-data is a test dependency; icub.urdf not found"
        path = found[0]
    return path


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def write_dataset(op2):
    """Write OP2 poses (n, 20) [rad] and CoPs (n, 2) [m] as the CSV ``sescid identify`` reads."""
    from sescid.tables import write_table

    def write(path, q, cop):
        cols = {name: q[:, j] for j, name in enumerate(op2.joint_names)}
        write_table(path, cols | {"cop_x": cop[:, 0], "cop_y": cop[:, 1]})
        return path

    return write
