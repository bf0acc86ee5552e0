"""Packages load their public names on first use (``sescid.base.lazy``)."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

from sescid.errors import MissingExtraError

PACKAGES = ["estimation", "sensors", "bench", "planning", "io", "report", "session"]


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_name_resolves_from_the_module_the_table_names(package):
    pkg = importlib.import_module(f"sescid.{package}")
    table = pkg._EXPORTS
    assert set(table) <= set(pkg.__all__)
    for name in pkg.__all__:
        try:
            value = getattr(pkg, name)
        except MissingExtraError:  # a name of an extra this venv lacks
            continue
        if name in table:
            assert getattr(importlib.import_module(table[name]), name) is value
    assert "__getattr__" not in pkg.__all__
    assert set(table) <= set(dir(pkg))


def test_a_public_name_that_is_also_a_submodule_stays_the_public_object():
    """``planning.candidates`` is the function even after ``planning/candidates.py`` loads."""
    code = (
        "import sescid.planning.candidates, sescid.bench.real_robot, sescid.report.coverage\n"
        "import sescid.planning as p, sescid.bench as b, sescid.report as r\n"
        "from sescid.planning import candidates, compliance\n"
        "print(callable(p.candidates), callable(candidates), callable(compliance),\n"
        "      callable(b.real_robot), callable(r.coverage))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True"] * 5


def test_one_name_does_not_import_the_whole_package():
    """Asking ``sescid.estimation`` for ``Measurements`` leaves the consistent-masses QPs and
    the online estimator unloaded; asking for ``identify`` loads the estimation core."""
    code = (
        "import sys\n"
        "from sescid.estimation import Measurements\n"
        "print('sescid.estimation.consistent' in sys.modules, "
        "'sescid.estimation.online' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]
