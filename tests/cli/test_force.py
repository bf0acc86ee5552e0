"""``--force`` is the same on every command that writes a file, and does what it says.

Every command with an output option has the one ``--force`` of ``cli/common.py`` (same flag,
same help); without it a write-protected output (mode 0o444: the tests run as root, so the mode,
not the permission, is what ``check_outputs`` reads) is refused with one line and left as it
was; with it the output check passes.
"""

from __future__ import annotations

from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from sescid.cli import COMMANDS, cli
from sescid.cli.common import force_option

#: options naming a file or folder the command writes
OUTPUT_OPTIONS = {"out", "out_dir", "truth", "fit_out", "figure", "json_out"}
REFUSED = "the file is write-protected (--force replaces it)"


def _command(name: str) -> click.Command:
    cmd = cli.get_command(click.Context(cli), name)
    assert cmd is not None
    return cmd


def _shared_force() -> click.Option:
    (opt,) = force_option(click.command()(lambda force: None)).params
    assert isinstance(opt, click.Option)
    return opt


def test_every_command_that_writes_has_the_shared_force():
    """Each command with an output option has --force: the same flag and help as common's."""
    shared = _shared_force()
    writers = []
    for name in COMMANDS:
        params = {p.name: p for p in _command(name).params}
        if not OUTPUT_OPTIONS & set(params):
            continue
        writers.append(name)
        force = params.get("force")
        assert isinstance(force, click.Option), f"{name} writes but has no --force"
        assert (force.opts, force.secondary_opts, force.is_flag, force.help) == (
            shared.opts,
            shared.secondary_opts,
            shared.is_flag,
            shared.help,
        ), name
    # the three that write nothing (precompile: numba's cache)
    assert set(COMMANDS) - set(writers) == {"info", "truth", "precompile"}


def _protected(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("keep\n")
    path.chmod(0o444)
    return path


@pytest.fixture(scope="module")
def fit_and_data(tmp_path_factory):
    """A small least-squares fit and its data (for report, which checks its folder last)."""
    d = tmp_path_factory.mktemp("fit")
    data, fit = d / "d.csv", d / "fit.json"
    run = CliRunner().invoke
    assert run(cli, ["simulate", "--count", "60", "--out", str(data)]).exit_code == 0
    assert run(cli, ["identify", str(data), "--out", str(fit)]).exit_code == 0
    return fit, data


#: command → (its arguments, {ro} the protected output; the file under tmp_path to protect);
#: the inputs are missing files, so after the output check the command stops on them
X = "--robot {x}/no.urdf"
CASES = {
    "simulate": ("simulate --count 5 --out {ro}", "s.csv"),
    "demo": (f"demo {X} --out-dir {{tmp}}/demo", "demo/fit.json"),
    "identify": ("identify {x}/d.csv --out {ro}", "fit.json"),
    "predict": ("predict {x}/f.json {x}/p.csv --out {ro}", "p.csv"),
    "export": ("export {x}/f.json --out {ro}", "m.urdf"),
    "poses": (f"poses {X} --out {{tmp}}/p.csv --figure {{ro}}", "fig.png"),
    "experiment": (
        f"experiment {X} --poses {{x}}/p.csv --out {{tmp}}/r.csv --truth {{ro}}",
        "t.json",
    ),
    "bag": (f"bag {{x}}/b --map {{x}}/m.yaml {X} --out {{ro}}", "raw.csv"),
    "measure": (f"measure {{x}}/raw.csv {X} --out {{ro}}", "m.csv"),
    "fsr": (f"fsr {{x}}/raw.csv {X} --out {{ro}}", "m.csv"),
    "calibrate": (f"calibrate {{x}}/raw.csv {X} --out {{tmp}}/s.json --fit {{ro}}", "fit.json"),
    "session": (
        "session --adapter python:{x}/a.py:Robot --no-view --out-dir {tmp}/sess",
        "sess/fit.json",
    ),
    "report": ("report {fit} {data} --out-dir {tmp}/rep", "rep/report.html"),
    "audit": ("audit {x}/d.csv --models {x}/m.urdf --json {ro}", "a.json"),
    "compare": ("compare {x}/a.json {x}/b.json --json {ro}", "c.json"),
}


def _stub_report(fit, data, out_dir, options):
    """What ``write_report`` leaves in its folder, without the figures (the check is the CLI's)."""
    from types import SimpleNamespace

    (out_dir / "report.html").write_text("<html></html>\n")
    content = SimpleNamespace(cop=None, tau=None)
    return SimpleNamespace(html=out_dir / "report.html", figures=(), content=content)


def test_every_writing_command_is_covered():
    """A case below for each command with an output option."""
    writers = {n for n in COMMANDS if OUTPUT_OPTIONS & {p.name for p in _command(n).params}}
    assert set(CASES) == writers


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_write_protected_output_needs_force(name, tmp_path, fit_and_data, monkeypatch):
    """Without --force: exit 2, one line naming the file, the file untouched; with --force the
    output check passes (the command goes on and stops on its missing input, or succeeds)."""
    if name == "report":
        import sescid.cli.report

        monkeypatch.setattr(sescid.cli.report, "write_report", _stub_report)
    args, protect = CASES[name]
    ro = _protected(tmp_path / protect)
    fit, data = fit_and_data
    fill = {"ro": ro, "tmp": tmp_path, "x": tmp_path / "missing", "fit": fit, "data": data}
    argv = [a.format(**fill) for a in args.split()]
    res = CliRunner().invoke(cli, argv)
    assert res.exit_code == 2, res.output
    assert res.output == f"sescid: error: {ro}: {REFUSED}\n"
    assert ro.read_text() == "keep\n" and ro.stat().st_mode & 0o777 == 0o444
    res = CliRunner().invoke(cli, [*argv, "--force"])
    assert REFUSED not in res.output
    assert res.exit_code == 0 or str(tmp_path / "missing") in res.output, res.output
