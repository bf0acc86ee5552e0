"""docs/report.md says what the code does: its residual definition is the page's, its options
are the command's, its files are the ones written for each kind of data."""

from __future__ import annotations

import re
from pathlib import Path

from click.testing import CliRunner
from op2_stance import stable_poses

from sescid import identify
from sescid.cli import cli
from sescid.estimation import Measurements
from sescid.report import ReportOptions, report_content
from sescid.report.figure_jobs import figure_jobs
from sescid.report.text import RESIDUAL_DEFINITION

DOC = Path(__file__).resolve().parents[2] / "docs" / "report.md"


def _flat(text: str) -> str:
    return " ".join(text.split())


def test_residual_definition_is_the_pages():
    definition = RESIDUAL_DEFINITION.split(" The identified model")[0]
    assert _flat(definition) in _flat(DOC.read_text())


def test_documented_options_exist():
    shown = CliRunner().invoke(cli, ["report", "--help"]).output
    used = set(re.findall(r"sescid report [^\n`]*", DOC.read_text()))
    options = {o for line in used for o in re.findall(r"--[a-z-]+", line)}
    assert options and all(o in shown for o in options), options


def test_documented_files_are_the_ones_written(op2, tmp_path):
    """The files table: three always, two per kind (names from the jobs, nothing drawn)."""
    q = stable_poses(op2, 30, seed=3)
    joints = tuple(op2.joint_names)
    m = Measurements(q=q, cop=op2.cop(q), tau=op2.torques(q, joints=joints), tau_joints=joints)
    fit = identify(op2, m, total_mass=op2.total_mass)
    table = DOC.read_text().split("| file | shown when |")[1].split("\n\n")[0]
    documented = {
        when.strip(): set(re.findall(r"`([a-z0-9_]+\.png)`", files))
        for files, when in re.findall(r"\|([^|]*)\|([^|]*)\|", table)
        if ".png" in files
    }
    for data, kinds in ((m, ("always", "CoP data", "torque data")),
                        (m.without("tau"), ("always", "CoP data")),
                        (m.without("cop"), ("always", "torque data"))):  # fmt: skip
        content = report_content(fit, data.checked(op2), ReportOptions())
        names = {j.name for j in figure_jobs(content, tmp_path, ReportOptions())}
        assert names == set().union(*(documented[k] for k in kinds))
