"""Compiled kernels ahead of the first run: the cache a package carries serves a cache folder of
the user's (seeded), a terminal is told once when kernels compile, the build backend asks for
what the precompile step needs, and the precompile step's command list covers the commands."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

MODULE = """
from sescid.kinematics.compile import lazy_njit, load_group


@lazy_njit(group="sescid.probe_seed", cache=True)
def twice(x):
    return 2.0 * x


def run():
    from sescid.kinematics import counting_compiles

    with counting_compiles() as names:
        load_group("sescid.probe_seed")
        value = twice(3.0)
    return value, names
"""

#: loads the module file as a sescid module (counting_compiles counts sescid's kernels)
RUN = """
import importlib.util, sys
spec = importlib.util.spec_from_file_location("sescid.probe_seed", sys.argv[1])
mod = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = mod
spec.loader.exec_module(mod)
v, names = mod.run()
print(v, len(names))
"""


def _run(folder: Path, cache: Path | None) -> list[str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env["PYTHONPATH"] = str(ROOT / "src")
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    out = subprocess.run(
        [sys.executable, "-c", RUN, str(folder / "seedmod.py")],
        env=env, capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


def test_a_cache_folder_of_the_users_is_seeded_from_the_packages(tmp_path):
    """The kernel compiled once beside its module (what a wheel carries) is loaded, not
    compiled, by a process whose numba caches elsewhere (NUMBA_CACHE_DIR, or the user's folder
    when the package's is read-only)."""
    folder = tmp_path / "pkg"
    folder.mkdir()
    (folder / "seedmod.py").write_text(textwrap.dedent(MODULE))
    assert _run(folder, None) == ["6.0", "1"]  # compiled, cached beside the module
    assert list((folder / "__pycache__").glob("seedmod.twice-*.nbi"))  # numba: file stem
    cache = tmp_path / "user-cache"
    assert _run(folder, cache) == ["6.0", "0"]  # seeded: loaded, no compile
    assert list(cache.rglob("seedmod.twice-*.nbi"))
    assert _run(folder, cache) == ["6.0", "0"]


NOTICE = """
from sescid.kinematics.compile import lazy_njit, load_group


@lazy_njit(group="sescid.probe_notice", cache=True)
def one(x):
    return x + 1.0


@lazy_njit(group="sescid.probe_notice", cache=True)
def two(x):
    return x + 2.0


def run():
    load_group("sescid.probe_notice")
    print(one(1.0) + two(1.0))
"""

#: loads the probe file as a sescid module (the notice is for sescid's kernels only)
PROBE = """
import importlib.util, sys
spec = importlib.util.spec_from_file_location("sescid.probe_notice", sys.argv[1])
mod = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = mod
spec.loader.exec_module(mod)
mod.run()
"""


def _stderr_of(probe: Path, tty: bool) -> str:
    """What a fresh process calling the probe's two kernels wrote on its stderr (a terminal or
    a pipe)."""
    import pty

    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env["PYTHONPATH"] = str(ROOT / "src")
    args = [sys.executable, "-c", PROBE, str(probe)]
    if not tty:
        out = subprocess.run(args, env=env, capture_output=True, text=True, check=True)
        assert out.stdout.split() == ["5.0"]
        return out.stderr
    main, sub = pty.openpty()
    try:
        out = subprocess.run(args, env=env, stdout=subprocess.PIPE, stderr=sub, check=True)
        assert out.stdout.split() == [b"5.0"]
        os.close(sub)
        chunks = []
        while True:
            try:
                data = os.read(main, 4096)
            except OSError:  # the terminal's other side is closed: all read
                break
            if not data:
                break
            chunks.append(data)
    finally:
        os.close(main)
    return b"".join(chunks).decode().replace("\r\n", "\n")


def test_a_terminal_is_told_once_when_kernels_compile(tmp_path):
    """One line on a terminal's stderr before the first of sescid's kernels compiles in a
    process (two compile here); nothing once they are in the cache, nothing on a pipe."""
    from sescid.kinematics.compile import COMPILING

    probe = tmp_path / "probe.py"
    probe.write_text(textwrap.dedent(NOTICE))
    assert _stderr_of(probe, tty=True) == COMPILING + "\n"
    assert _stderr_of(probe, tty=True) == ""  # loaded from the cache
    (tmp_path / "__pycache__").rename(tmp_path / "old")
    assert _stderr_of(probe, tty=False) == ""  # compiled again, quietly on a pipe


def _backend():
    path = ROOT / "tools" / "build_backend" / "sescid_build.py"
    spec = importlib.util.spec_from_file_location("sescid_build", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_build_backend_asks_for_the_projects_dependencies(monkeypatch):
    """A wheel's build environment gets the project's own dependencies (read from
    pyproject.toml, not written twice), unless SESCID_PRECOMPILE=0; an editable build does not
    (setuptools' own requirements stubbed: this venv's setuptools may be older than a build's)."""
    backend = _backend()
    monkeypatch.chdir(ROOT)
    monkeypatch.setattr(backend._setuptools, "get_requires_for_build_wheel", lambda cs=None: ["w"])
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    monkeypatch.delenv(backend.SWITCH, raising=False)
    assert backend.get_requires_for_build_wheel() == ["w", *deps]
    assert (
        backend.get_requires_for_build_editable
        is backend._setuptools.get_requires_for_build_editable
    )
    monkeypatch.setenv(backend.SWITCH, "0")
    assert backend.get_requires_for_build_wheel() == ["w"]


def test_the_build_step_never_fails_the_build(tmp_path, capsys):
    """Where the kernels cannot be compiled (here: a build folder without sescid), the step
    says so in one line and returns; the wheel is built without kernels."""
    backend = _backend()
    assert backend.precompile(str(tmp_path)) is False
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("sescid build: kernels not compiled (")


def test_pyproject_builds_with_the_backend():
    """pyproject.toml names the backend and its build_py (so a plain `pip install .` runs it),
    and the sdist carries the backend."""
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert data["build-system"]["build-backend"] == "sescid_build"
    assert data["build-system"]["backend-path"] == ["tools/build_backend"]
    assert data["tool"]["setuptools"]["cmdclass"]["build_py"] == "sescid_build.BuildPy"
    assert "tools/build_backend/sescid_build.py" in (ROOT / "MANIFEST.in").read_text()


@pytest.mark.slow
def test_after_precompile_the_commands_compile_nothing(tmp_path):
    """A copy of the package without any compiled kernel: ``sescid precompile``, then the
    planner's and the fit's commands in fresh processes compile no kernel (they load every one
    from the cache precompile wrote beside the modules)."""
    import shutil

    src = tmp_path / "src"
    shutil.copytree(ROOT / "src" / "sescid", src / "sescid",
                    ignore=shutil.ignore_patterns("__pycache__"))  # fmt: skip
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env["PYTHONPATH"] = str(src)
    cli = "import sys; from sescid.cli import main; sys.argv[0] = 'sescid'; main()"
    pre = subprocess.run(
        [sys.executable, "-c", cli, "precompile"], env=env, cwd=tmp_path, capture_output=True,
        text=True, check=False,
    )  # fmt: skip
    assert pre.returncode == 0, pre.stderr
    check = textwrap.dedent(
        """
        import sys
        from sescid.cli import cli
        from sescid.kinematics import counting_compiles
        with counting_compiles() as names:
            try:
                cli.main(args=sys.argv[1:], prog_name="sescid", standalone_mode=False)
            except SystemExit as exc:
                assert not exc.code, exc.code
        print("compiled:", *sorted(set(names)))
        """
    )
    commands = [
        ["poses", "--count", "38", "--seed", "1", "--out", "poses.csv"],
        ["poses", "--kinds", "both", "--seed", "1", "--out", "pb.csv"],
        ["simulate", "--poses", "50000", "--measure", "both", "--out", "sim.csv"],
        ["identify", "sim.csv", "--out", "fit.json"],
        ["identify", "sim.csv", "--kinds", "tau", "--out", "ft.json"],
        ["predict", "fit.json", "sim.csv", "--out", "pred.csv"],
    ]
    for args in commands:
        out = subprocess.run(
            [sys.executable, "-c", check, *args], env=env, cwd=tmp_path, capture_output=True,
            text=True, check=False,
        )  # fmt: skip
        assert out.returncode == 0, out.stderr
        assert out.stdout.splitlines()[-1] == "compiled:", (args, out.stdout[-500:])


FAST = """
import numpy as np

from sescid.kinematics.compile import lazy_njit, load_group


@lazy_njit(group="sescid.probe_fast", cache=True)
def doubled(n):
    return np.ones(n) * 2.0  # an array: the runtime's allocator


@lazy_njit(group="sescid.probe_fast", cache=True)
def total(x):
    s = 0.0
    for v in x:
        s += v
    return s
"""

#: calls ``doubled`` (cached by the first run), then, second run only, ``total`` (compiled)
FAST_RUN = """
import importlib.util, sys
spec = importlib.util.spec_from_file_location("sescid.probe_fast", sys.argv[1])
mod = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = mod
spec.loader.exec_module(mod)
from sescid.kinematics import counting_compiles
with counting_compiles() as names:
    mod.load_group("sescid.probe_fast")
    a = mod.doubled(3)
    loaded = sorted(m for m in ("scipy.linalg", "numba.typed.typedlist") if m in sys.modules)
    print(a.sum(), len(names), *loaded)
    if sys.argv[2] == "both":
        print(mod.total(a), len(names), "numba.typed.typedlist" in sys.modules)
"""


def test_cached_kernels_load_without_numbas_compile_registries(tmp_path):
    """A kernel loaded from the cache runs without numba's typing and lowering registries
    (typed containers, linalg and the scipy.linalg it imports: 0.3–0.5 s a process); a kernel
    that must compile afterwards in the same process loads them and compiles as before."""
    (tmp_path / "fastmod.py").write_text(textwrap.dedent(FAST))
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env["PYTHONPATH"] = str(ROOT / "src")

    def run(which: str) -> list[str]:
        out = subprocess.run(
            [sys.executable, "-c", FAST_RUN, str(tmp_path / "fastmod.py"), which],
            env=env, capture_output=True, text=True, check=False,
        )  # fmt: skip
        assert out.returncode == 0, out.stderr
        return out.stdout.splitlines()

    first = run("one")  # compiles doubled (and loads the registries to do so)
    assert first[0].split()[:2] == ["6.0", "1"]
    assert run("both") == ["6.0 0", "6.0 1 True"]  # loaded bare; total compiled after it
