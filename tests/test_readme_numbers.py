"""The README's walk-through figures are those of a verbatim run (tools/readme_numbers.py)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.slow
def test_readme_quotes_a_verbatim_run():
    """Every figure the walk-through section quotes, at its printed precision, is what the
    commands give now."""
    spec = importlib.util.spec_from_file_location(
        "readme_numbers", ROOT / "tools/readme_numbers.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## On a real OP2") : readme.index("## Pose planning")]
    for line in mod.COMMANDS:
        assert line.replace(" --truth", "\n    --truth") in section or line in section, line
    figures = mod.walk_through()
    figures.pop("seconds")
    missing = {k: v for k, v in figures.items() if v not in section}
    assert not missing, f"README quotes other figures than a run gives: {missing}"
