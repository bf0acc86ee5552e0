"""Docs that cannot drift from the command line.

- docs/cli.md is exactly what tools/cli_reference.py writes from the commands;
- every ``sescid <command> …`` in README.md and docs/*.md (code blocks and inline code) names a
  command that exists and only options that its ``--help`` lists; an inline ``--option`` alone
  must be an option of some command.

The README's walk-through commands are run verbatim by tests/test_readme_numbers.py (slow).
"""

from __future__ import annotations

import functools
import importlib.util
import re
from pathlib import Path

import click
from click.testing import CliRunner

from sescid.cli import COMMANDS, cli

ROOT = Path(__file__).resolve().parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: a shell operator or comment ends a command line
END = {"|", "||", "&&", ";", ">", ">>", "<", "2>", "&"}
FENCE = re.compile(r"^(```|~~~)[^\n]*\n(.*?)^\1", re.M | re.S)
#: an inline code span (it may wrap, not across a blank line)
SPAN = re.compile(r"`([^`\n]+(?:\n[^`\n]+)*)`")
OPTION = re.compile(r"(?<![\w-])(--?[A-Za-z][\w-]*)")


def _tool():
    spec = importlib.util.spec_from_file_location("cli_reference", ROOT / "tools/cli_reference.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_cli_reference_is_generated_from_the_commands():
    """docs/cli.md equals the output of tools/cli_reference.py (run it after changing a command)."""
    page = (ROOT / "docs" / "cli.md").read_text()
    assert page == _tool().render(), "docs/cli.md is out of date: run python tools/cli_reference.py"


def test_the_reference_names_every_command_and_option():
    """The generated page has a section per command and a row per option (so it cannot be thin)."""
    page = _tool().render()
    for name in COMMANDS:
        assert f"\n## sescid {name}\n" in page
        cmd = cli.get_command(click.Context(cli), name)
        assert cmd is not None
        for p in cmd.params:
            if isinstance(p, click.Option) and name != "fsr":  # fsr: the alias of measure
                long = max(p.opts, key=len)  # its row's first cell (after a short spelling)
                assert re.search(rf"\n\| (`-\w` / )?`{long}`", page), (name, p.opts)


def code_pieces(text: str) -> list[str]:
    """The code in Markdown text: each line of a fenced block (continuations joined) and each
    inline code span."""
    out = []
    for m in FENCE.finditer(text):
        out += m.group(2).replace("\\\n", " ").splitlines()
    out += [m.group(1).replace("\n", " ") for m in SPAN.finditer(FENCE.sub("", text))]
    return out


def invocations(piece: str) -> list[tuple[str, list[str]]]:
    """(command, options used) of each ``sescid <command> …`` in a piece of code; a span that
    starts with a bare command name followed by options counts too (``poses --seed 0``); a
    span of options alone is ('', options). The command '' is the group (``sescid --version``)."""
    words = piece.split()
    found = []
    starts = [i + 1 for i, w in enumerate(words) if w.lstrip("$(") == "sescid"]
    if words and words[0] in COMMANDS and any(w.startswith("--") for w in words):
        starts.insert(0, 0)
    elif words and words[0].startswith("--"):
        return [("*", [o for w in words for o in _options_in(w)])]
    for i in starts:
        rest = words[i:]
        if not rest or rest[0].startswith(("[", "…")) or rest[0].isupper():
            continue  # a placeholder: sescid [OPTIONS] COMMAND
        command = "" if rest[0].startswith("-") else rest[0]
        used = []
        for w in rest:
            if w in END or w.startswith(("#", "`")):
                break
            used += _options_in(w)
        found.append((command, used))
    return found


def _options_in(word: str) -> list[str]:
    """The options a word names: ``--a``, ``--a=1``, ``--a/--b``, ``[--a``."""
    word = word.lstrip("[(").rstrip("]),.;:")
    return [o for o in word.split("=")[0].split("/") if o.startswith("-") and OPTION.fullmatch(o)]


@functools.cache
def script_options() -> frozenset[str]:
    """Options of the repository's scripts (examples/, tools/, benchmarks/: argparse)."""
    found: set[str] = set()
    for folder in ("examples", "tools", "benchmarks"):
        for path in (ROOT / folder).rglob("*.py"):
            found |= set(re.findall(r"add_argument\(\s*[\"'](--[\w-]+)", path.read_text()))
    return frozenset(found)


@functools.cache
def help_options(command: str) -> frozenset[str] | None:
    """The options a command's ``--help`` lists (None: no such command); '*': any command's or
    a repository script's (an option alone in the text may be an example script's)."""
    if command == "*":
        every = [help_options(c) or frozenset() for c in COMMANDS]
        return frozenset().union(script_options(), *every)
    if command and command not in COMMANDS:
        return None
    res = CliRunner().invoke(cli, [command, "--help"] if command else ["--help"])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    # the option sections: from the first title line ("Options:", or identify's "Data:")
    first = next(i for i, t in enumerate(lines) if i and t[:1].strip() and t.endswith(":"))
    listed = "\n".join(lines[first:]).split("Commands:", 1)[0]
    return frozenset(OPTION.findall(listed))


def problems(text: str) -> list[str]:
    """Each command or option a Markdown text names that the command line does not have."""
    out = []
    for piece in code_pieces(text):
        for command, used in invocations(piece):
            known = help_options(command)
            if known is None:
                out.append(f"`{piece.strip()}`: no command '{command}'")
                continue
            for o in (o for o in used if o not in known):
                what = f"sescid {command} has no {o}" if command != "*" else f"{o} is no option"
                out.append(f"`{piece.strip()}`: {what}")
    return out


def test_commands_in_the_readme_and_docs_exist_with_their_options():
    """Every command the README and docs/*.md show runs --help and lists each option used."""
    bad = [f"{path.name}: {p}" for path in DOCS for p in problems(path.read_text())]
    assert not bad, "\n".join(bad)
    shown = {c for path in DOCS for piece in code_pieces(path.read_text())
             for c, _ in invocations(piece)}  # fmt: skip
    assert {"identify", "poses", "experiment", "session", ""} <= shown  # the scan sees them


def test_an_option_that_does_not_exist_is_caught():
    """`poses --double-support` (an experiment option) and an unknown command are reported."""
    text = (
        "Plan with `sescid poses --double-support --count 38`, then\n\n"
        "```bash\nsescid experiment --poses p.csv \\\n  --double-support --out r.csv  # ok\n"
        "sescid plan --out x.csv\n```\nand `identify --robust-k 3`; `--no-such-flag` alone.\n"
    )
    assert problems(text) == [
        "`sescid plan --out x.csv`: no command 'plan'",
        "`sescid poses --double-support --count 38`: sescid poses has no --double-support",
        "`identify --robust-k 3`: sescid identify has no --robust-k",
        "`--no-such-flag`: --no-such-flag is no option",
    ]


def test_the_docs_index_lists_every_page():
    """docs/README.md links every page of docs/, and each of its links exists."""
    index = (ROOT / "docs" / "README.md").read_text()
    links = set(re.findall(r"\]\(([^)#\s]+)\)", index))
    pages = {p.name for p in (ROOT / "docs").glob("*.md")} - {"README.md"}
    assert pages <= links, f"pages missing from docs/README.md: {sorted(pages - links)}"
    missing = [link for link in links if not (ROOT / "docs" / link).exists()]
    assert not missing, f"docs/README.md links to missing files: {missing}"
