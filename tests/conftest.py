"""Shared fixtures: the embedded OP2, a public humanoid URDF, the Pinocchio oracle."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))

import sescid  # noqa: E402

# One BLAS thread: the tests' matrices are small, and a thread pool per process only
# oversubscribes the cores when pytest or other jobs run beside it.
threadpool_limits(1)


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
