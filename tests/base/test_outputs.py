"""Outputs never destroy inputs, devices, directories or protected files (CLI and files)."""

from __future__ import annotations

import os

import pytest
from click.testing import CliRunner

from sescid.base.files import atomic_open, check_outputs
from sescid.cli import cli
from sescid.errors import DataError


def _sim(tmp_path):
    data = tmp_path / "d.csv"
    res = CliRunner().invoke(cli, ["simulate", "--count", "60", "--out", str(data)])
    assert res.exit_code == 0, res.output
    return data


def test_identify_refuses_to_overwrite_its_data(tmp_path):
    """`identify d.csv --out d.csv` exits 2 with one line and leaves the data intact."""
    data = _sim(tmp_path)
    before = data.read_bytes()
    res = CliRunner().invoke(cli, ["identify", str(data), "--out", str(data)])
    assert res.exit_code == 2 and "also an input" in res.output
    assert res.output.count("\n") == 1 and data.read_bytes() == before


def test_predict_refuses_its_pose_file_through_a_symlink(tmp_path):
    """An output that is an input under another name (a symlink) is refused too."""
    data = _sim(tmp_path)
    fit = tmp_path / "fit.json"
    assert CliRunner().invoke(cli, ["identify", str(data), "--out", str(fit)]).exit_code == 0
    link = tmp_path / "link.csv"
    link.symlink_to(data)
    res = CliRunner().invoke(cli, ["predict", str(fit), str(data), "--out", str(link)])
    assert res.exit_code == 2 and "also an input" in res.output


def test_devices_directories_and_protected_files_are_refused(tmp_path):
    """/dev/null, a folder and a read-only file are not output targets."""
    with pytest.raises(DataError, match="device or pipe"):
        check_outputs(["/dev/null"], [])
    with pytest.raises(DataError, match="directory"):
        check_outputs([tmp_path], [])
    ro = tmp_path / "ro.csv"
    ro.write_text("x\n")
    ro.chmod(0o444)
    with pytest.raises(DataError, match="write-protected"):
        check_outputs([ro], [])
    with pytest.raises(DataError, match="twice"):
        check_outputs([tmp_path / "a", tmp_path / "a"], [])


def test_atomic_write_through_a_symlink_keeps_the_link(tmp_path):
    """Writing to a symlink replaces its target's content; the link stays a link."""
    target = tmp_path / "t.txt"
    target.write_text("old")
    link = tmp_path / "l.txt"
    link.symlink_to(target)
    with atomic_open(link) as fh:
        fh.write("new")
    assert link.is_symlink() and target.read_text() == "new"
    assert os.readlink(link) == str(target)
