"""The figures of docs/torques.md's walk-through, from running its commands as written.

    python tools/torques_walkthrough.py            # runs the page's block, rewrites the sentence
    python tools/torques_walkthrough.py --check    # exit 1 when the page quotes other figures

Runs the walk-through's shell block (the one after "## Walk-through" in docs/torques.md, read
from the page itself) in a temporary folder with the ``sescid`` next to this Python, reads what
``sescid truth`` prints (RMS CoP error of the identified and the manufacturer's model against the
bench's real robot, at the measured poses and at fresh ones) and writes the sentence that quotes
them between the page's markers. About 40 s on this 2-core machine (the physics bench).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

from doc_blocks import spliced

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "torques.md"
START, END = (
    "<!-- torques-walkthrough: tools/torques_walkthrough.py -->",
    "<!-- /torques-walkthrough -->",
)
ACTUAL = re.compile(r"at the (\d+) actual poses: identified ([\d.]+) mm, manufacturer ([\d.]+) mm")
FRESH = re.compile(r"at (\d+) fresh poses [^:]*: identified ([\d.]+) mm, manufacturer ([\d.]+) mm")


def block(page: str) -> str:
    """The walk-through's shell block of the page."""
    section = page.split("## Walk-through", 1)[1]
    return section.split("```sh\n", 1)[1].split("```", 1)[0]


def run(commands: str) -> str:
    """The commands' standard output, run by bash in a temporary folder."""
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    with tempfile.TemporaryDirectory() as tmp:
        res = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", commands], cwd=tmp, env=env,
                             capture_output=True, text=True, check=False)  # fmt: skip
    if res.returncode != 0:
        sys.exit(f"the walk-through failed:\n{res.stdout}\n{res.stderr}")
    return res.stdout


def sentence(printed: str) -> str:
    """The page's sentence quoting ``sescid truth``'s figures."""
    a, f = ACTUAL.search(printed), FRESH.search(printed)
    if a is None or f is None:
        sys.exit(f"sescid truth printed no figures:\n{printed}")
    text = (
        f"the {a[1]} measured poses the identified CoP (the CoM's ground projection) is within "
        f"{a[2]} mm (RMS) of the real robot's against {a[3]} mm for the manufacturer's model, "
        f"and {f[2]} mm against {f[3]} mm on {f[1]} fresh poses near them "
        "(`python tools/torques_walkthrough.py` runs the block above and writes these figures)."
    )
    return textwrap.fill(text, 100, break_on_hyphens=False)


def main() -> None:
    text = DOC.read_text()
    new = spliced(text, START, END, sentence(run(block(text))))
    if "--check" in sys.argv:
        if new != text:
            print("docs/torques.md quotes other figures than its walk-through gives now")
            sys.exit(1)
        return
    DOC.write_text(new)
    print(new.split(START, 1)[1].split(END, 1)[0].strip())


if __name__ == "__main__":
    main()
