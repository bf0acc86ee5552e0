"""sescid's build backend: setuptools, plus the numba kernels compiled into the wheel.

``pip install .`` and ``pip wheel .`` build a wheel; this backend has setuptools build it, and
after ``build_py`` has copied the package into the build folder it runs ``sescid precompile``
on that copy, in a fresh process, so numba's cache files (``__pycache__/*.nbi``, ``*.nbc``
beside each kernel module) go into the wheel. The first command after installing then loads
its kernels instead of compiling them. To run it, the wheel's build environment gets the
project's own dependencies (``get_requires_for_build_wheel``: read from ``pyproject.toml``,
not written twice).

numba keys its cache by its version, the kernels' source, their signatures and the CPU (name
and features): the kernels fit the machine that built the wheel (``pip install .`` builds on
the installing machine). Elsewhere the first call compiles, as without this step.

It never fails the build: if the kernels cannot be compiled (no numba for this platform, a
build without isolation and without the dependencies, a timeout), it says so in one line and
the wheel has no kernels. ``SESCID_PRECOMPILE=0`` skips it (a wheel built for other machines).
An editable install (``pip install -e``) skips it too: the source folder's ``__pycache__`` is
the cache there.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

from setuptools import build_meta as _setuptools
from setuptools.build_meta import *  # noqa: F403 - every other PEP 517 hook is setuptools'
from setuptools.command.build_py import build_py

#: the switch that skips the step (``0``, ``no``, ``false``, ``off``)
SWITCH = "SESCID_PRECOMPILE"
#: seconds the step may take before the wheel is built without kernels
TIMEOUT = 1800
#: the command run on the built copy of the package (argv[1]): refused if Python imports
#: sescid from elsewhere (an installed or editable copy would get the cache files instead)
COMMAND = """
import sys
from pathlib import Path
import sescid
lib = Path(sys.argv[1]).resolve()
if lib not in Path(sescid.__file__).resolve().parents:
    sys.exit(f"sescid is imported from {Path(sescid.__file__).parent}, not from {lib}")
from sescid.cli import main
sys.argv = ["sescid", "precompile"]
main()
"""


def _project_dependencies() -> list[str]:
    """``[project] dependencies`` of the ``pyproject.toml`` being built."""
    with open("pyproject.toml", "rb") as f:
        return list(tomllib.load(f)["project"]["dependencies"])


def _wanted() -> bool:
    return os.environ.get(SWITCH, "1").strip().lower() not in ("0", "no", "false", "off")


def get_requires_for_build_wheel(config_settings=None):
    """setuptools' requirements, and the project's own (to compile its kernels)."""
    extra = _project_dependencies() if _wanted() else []
    return [*_setuptools.get_requires_for_build_wheel(config_settings), *extra]


def _say(message: str) -> None:
    print(f"sescid build: {message}", file=sys.stderr, flush=True)


def precompile(build_lib: str) -> bool:
    """Run ``sescid precompile`` on the package copied into ``build_lib``: numba writes its
    cache beside the copied modules. True when it succeeded; never raises."""
    env = dict(os.environ)
    lib = str(Path(build_lib).resolve())
    # the copy in build_lib first, then whatever the build environment put on the path
    env["PYTHONPATH"] = os.pathsep.join([lib, *filter(None, [env.get("PYTHONPATH")])])
    env.pop("NUMBA_CACHE_DIR", None)  # the cache goes beside the modules, into the wheel
    env.pop("NUMBA_DISABLE_JIT", None)
    env["PYTHONDONTWRITEBYTECODE"] = "1"  # numba's files in the wheel, not the modules' .pyc
    _say("compiling the numba kernels for this CPU into the wheel (about a minute)")
    start = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory(prefix="sescid-build-") as cwd:
            done = subprocess.run(
                [sys.executable, "-c", COMMAND, lib],
                cwd=cwd,
                env=env,
                capture_output=True,
                text=True,
                timeout=TIMEOUT,
                check=False,
            )
    except (OSError, subprocess.SubprocessError) as exc:
        _say(f"kernels not compiled ({exc}); they compile on first use")
        return False
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        _say(f"kernels not compiled ({last}); they compile on first use")
        return False
    for line in done.stdout.strip().splitlines():
        _say(line)
    _say(f"[{time.perf_counter() - start:.0f} s]")
    return True


class BuildPy(build_py):
    """``build_py``, then the kernels compiled into the copy (not for an editable install)."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False) or not _wanted():
            return
        precompile(self.build_lib)
