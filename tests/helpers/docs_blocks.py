"""The runnable code blocks of README.md and docs/*.md, as the docs tests run them.

A fenced block tagged ``sh``/``bash`` runs with bash in one temporary folder per page, in page
order (a block may use the files an earlier block of its page wrote); one tagged ``python``
runs there too (``exec``, the page's blocks sharing one namespace). A block without a
``sescid`` command (``make demo``) is not run here. What a block needs is said in an HTML
comment on the line just above its fence:

- ``<!-- docs-test: needs mujoco -->`` (an extra's module, or ``example-robot-data``, whose
  robots the page names): the page is skipped without;
- ``<!-- docs-test: slow -->``: runs with ``make slow`` (``-m slow``), not in ``make test``;
- ``<!-- docs-test: after walkthrough -->``: the page's folder first gets the files of the
  walk-through's commands (a pose list, raw log, measured file, fit, truth);
- ``<!-- docs-test: clone -->``: the block names a file of the repository's ``examples/`` (a
  file to copy, such as a session adapter, which the page says): the folder gets ``examples/``
  linked in. No other block may name a path of the clone.

A block runs in an empty folder outside the repository (``clone`` blocks aside): it names models
by an embedded or
example name (``op2``, ``wheeled_humanoid``) or by a path it computes (example-robot-data's
``robots/`` folder from the environment's ``site-packages``), never by a path of the clone.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```", re.M | re.S)
MARK = re.compile(r"<!--\s*docs-test:\s*(.*?)\s*-->\s*$")


@dataclass(frozen=True)
class Block:
    """One runnable code block: its page, line, language, text and marks."""

    page: str
    line: int
    lang: str  #: "sh" or "python"
    text: str
    needs: tuple[str, ...] = ()  #: modules it imports beyond the core (extras)
    slow: bool = False
    after: str = ""  #: a set of files it needs first ("walkthrough")
    clone: bool = False  #: names a file of the repository's examples/ (linked in)

    @property
    def id(self) -> str:
        """``page:line``, the block's name in test ids and messages."""
        return f"{self.page}:{self.line}"


def blocks(path: Path) -> list[Block]:
    """The runnable blocks of one page, in order."""
    text = path.read_text()
    out = []
    for m in FENCE.finditer(text):
        lang = {"bash": "sh", "sh": "sh", "python": "python"}.get(m.group(1))
        body = m.group(2)
        if lang is None or (lang == "sh" and not re.search(r"^\s*sescid\s", body, re.M)):
            continue
        line = text.count("\n", 0, m.start()) + 1
        before = text[: m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        needs, slow, after, clone = [], False, "", False
        mark = MARK.search(before)
        for part in (p.strip() for p in (mark.group(1) if mark else "").split(";")):
            if part.startswith("needs "):
                needs += part[len("needs ") :].split()
            elif part == "slow":
                slow = True
            elif part == "clone":
                clone = True
            elif part.startswith("after "):
                after = part[len("after ") :]
        rel = path.relative_to(ROOT).as_posix()
        out.append(Block(rel, line, lang, body, tuple(needs), slow, after, clone))
    return out


def every_block() -> list[Block]:
    """The runnable blocks of every page."""
    return [b for p in PAGES for b in blocks(p)]
