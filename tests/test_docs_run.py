"""Every runnable code block of README.md and docs/*.md runs as written
(tests/helpers/docs_blocks.py says which blocks and how): each page's blocks in order, in an
empty folder of their own outside the repository (nothing of a clone linked in), the commands
exiting 0; a Python block in a namespace the page's blocks
share."""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from docs_blocks import PAGES, ROOT, Block, blocks

#: the walk-through's commands, for pages that continue from its files
WALKTHROUGH = """
sescid poses --robot op2 --count 38 --select d-optimal --seed 0 --out poses.csv
sescid experiment --robot op2 --poses poses.csv --samples 100 --seed 0 --out raw.csv \\
    --truth truth.json
sescid measure raw.csv --robot op2 --poses poses.csv --out measured.csv
sescid identify measured.csv --robot op2 --weighted --out fit.json
"""


def _erd_robots() -> Path | None:
    """example-robot-data's robots/ folder (a test dependency), or None."""
    try:
        import cmeel  # type: ignore[import-not-found]
    except ImportError:
        return None
    found = Path(cmeel.__file__).resolve().parent.parent / "cmeel.prefix" / "share"
    robots = found / "example-robot-data" / "robots"
    return robots if robots.is_dir() else None


def _have(need: str) -> bool:
    """A block's need is met: a module that imports, or example-robot-data's robots."""
    if need == "example-robot-data":
        return _erd_robots() is not None
    return importlib.util.find_spec(need) is not None


def _folder(tmp: Path, clone: bool = False) -> Path:
    """The run's folder: an empty one outside the repository, as a user's after `pip install`
    (the docs name models by an embedded or example name, or by a path they compute); the
    repository's examples/ linked in only for a page with a ``clone`` block."""
    assert not tmp.resolve().is_relative_to(ROOT)
    if clone:
        (tmp / "examples").symlink_to(ROOT / "examples")
    return tmp


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["MPLBACKEND"] = "Agg"
    return env


def _sh(text: str, cwd: Path, what: str) -> None:
    res = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", text], cwd=cwd, env=_env(),
                         capture_output=True, text=True, timeout=1800)  # fmt: skip
    assert res.returncode == 0, (
        f"{what} failed (exit {res.returncode}):\n{res.stdout}\n{res.stderr}"
    )


def run_page(page: Path, tmp: Path) -> None:
    """Run one page's blocks in order in ``tmp`` (skip when a block needs a missing module)."""
    todo = blocks(page)
    missing = sorted({m for b in todo for m in b.needs if not _have(m)})
    if missing:
        pytest.skip(f"{page.name} needs {', '.join(missing)}")
    cwd = _folder(tmp, any(b.clone for b in todo))
    namespace: dict = {"__name__": "__docs__"}
    done_after: set[str] = set()
    old = Path.cwd()
    for b in todo:
        if b.after == "walkthrough" and b.after not in done_after:
            _sh(WALKTHROUGH, cwd, f"{b.id}: the walk-through's files")
            done_after.add(b.after)
        if b.lang == "sh":
            _sh(b.text, cwd, b.id)
            continue
        os.chdir(cwd)
        try:
            exec(compile(b.text, b.id, "exec"), namespace)  # noqa: S102 - the docs' own code
        finally:
            os.chdir(old)


def _params():
    out = []
    for page in PAGES:
        bs: list[Block] = blocks(page)
        if not bs:
            continue
        marks = [pytest.mark.slow] if any(b.slow for b in bs) else []
        out.append(pytest.param(page, id=page.relative_to(ROOT).as_posix(), marks=marks))
    return out


@pytest.mark.parametrize("page", _params())
def test_the_page_runs_as_written(page: Path, tmp_path: Path):
    """The page's code blocks, in order, as a reader would type them."""
    run_page(page, tmp_path)


def test_the_blocks_are_found():
    """The scan sees the README's walk-through and API blocks and a docs page's, and skips a
    block without a sescid command (make demo)."""
    readme = blocks(ROOT / "README.md")
    assert [b.lang for b in readme] == ["sh", "python"]
    assert "sescid poses" in readme[0].text and "import sescid" in readme[1].text
    assert all("make demo" not in b.text for b in readme)
    assert shutil.which("bash") is not None


def test_no_block_names_a_file_of_the_clone():
    """No block names a path only a clone has (examples/, src/, tools/, …): a block runs from
    any folder with a plain install; a ``clone`` block (a file of examples/ to copy, which its
    page says) is the one exception."""
    import re

    clone = re.compile(r"(?:^|[\s=\"':])(?:\./)?(?:examples|src|tools|benchmarks|tests)/\S")
    found = [(b.id, line) for p in PAGES for b in blocks(p) for line in b.text.splitlines()
             if clone.search(line) and not b.clone]  # fmt: skip
    assert found == []
