"""A numba cache index left by another version of a kernel module does not crash the next run.

numba unpickles a cache index before it compares the source's stamp; an index whose signatures
name a record type (a NamedTuple argument) that the new source renamed raises AttributeError on
the first call. This happens on an upgrade (``__pycache__`` and user cache folders outlive an
install) or when switching branches. ``sescid.kinematics.compile`` empties such an index.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

MODULE = """
from typing import NamedTuple

from sescid.kinematics.compile import lazy_njit, load_group


class {name}(NamedTuple):
    a: float
    b: float


@lazy_njit(group="stalemod", cache=True)
def twice(p):
    return 2.0 * (p.a + p.b)


def run():
    load_group("stalemod")
    return twice({name}(1.0, 2.0))
"""


def _run(folder: Path, cache: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(folder))
    code = "import stalemod; print(stalemod.run())"
    return subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=False
    )


def test_an_index_naming_a_renamed_record_type_is_dropped(tmp_path):
    folder, cache = tmp_path / "src", tmp_path / "cache"
    folder.mkdir()
    module = folder / "stalemod.py"
    module.write_text(textwrap.dedent(MODULE.format(name="Pair")))
    first = _run(folder, cache)
    assert first.returncode == 0, first.stderr
    assert first.stdout.strip() == "6.0"
    assert list(cache.rglob("*.nbi")), "the first run wrote a cache index"
    # the next version renames the record type; the kernel keeps its line (same index file)
    module.write_text(textwrap.dedent(MODULE.format(name="Couple")))
    second = _run(folder, cache)
    assert second.returncode == 0, second.stderr
    assert second.stdout.strip() == "6.0"
    third = _run(folder, cache)  # and the index it rewrote serves the run after
    assert third.returncode == 0, third.stderr
    assert third.stdout.strip() == "6.0"
