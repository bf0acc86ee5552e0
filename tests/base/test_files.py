"""Outputs that destroy nothing and errors that name the output, never a temporary file."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sescid.base.files import OutputSet, atomic_open, atomic_path, check_outputs
from sescid.cli import cli
from sescid.errors import DataError
from sescid.tables import write_table

TEMP = re.compile(r"\.tmp|/\.[^/\s]*\.[0-9a-f]{8}")  # atomic_* and OutputSet temporaries


def test_output_inside_an_input_folder_is_refused(tmp_path):
    """A rosbag2 folder (or any input folder) is never written into, nor an output folder
    created inside it; beside it is fine."""
    rec = tmp_path / "rec"
    rec.mkdir()
    (rec / "metadata.yaml").write_text("keep\n")
    for out in (rec / "raw.csv", rec / "metadata.yaml", rec / "sub" / "raw.csv"):
        with pytest.raises(DataError, match=r"inside the input .*rec"):
            check_outputs([out], [rec])
    with pytest.raises(DataError, match="inside the input"):
        check_outputs([], [rec], folders=[rec / "report"])
    with pytest.raises(DataError, match="inside the input"):
        check_outputs([], [rec], folders=[rec])
    check_outputs([tmp_path / "raw.csv"], [rec])
    assert (rec / "metadata.yaml").read_text() == "keep\n"


def test_output_folder_not_writable(tmp_path, monkeypatch):
    """A folder the user cannot write to is refused before anything is computed (as root the
    permission bits do not stop writes, so access() is what the check asks)."""
    ro = tmp_path / "ro"
    ro.mkdir()
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, m: False if Path(p) == ro else real(p, m))
    with pytest.raises(DataError, match=r"ro/o.json: output folder '.*ro' is not writable"):
        check_outputs([ro / "o.json"], [])


def _deny_replace(monkeypatch):
    """os.replace fails as on a read-only folder, naming its source (the temporary)."""

    def deny(src, dst):
        raise PermissionError(13, "Permission denied", str(src), None, str(dst))

    monkeypatch.setattr(os, "replace", deny)


def test_atomic_writers_name_the_output(tmp_path, monkeypatch):
    """atomic_open/atomic_path: a failed replace or temporary names the output."""
    _deny_replace(monkeypatch)
    out = tmp_path / "o.json"
    with pytest.raises(DataError) as exc, atomic_open(out) as fh:
        fh.write("{}")
    assert str(exc.value) == f"{out}: cannot write (Permission denied)"
    with pytest.raises(DataError) as exc, atomic_path(out) as tmp:
        tmp.write_text("{}")
    assert str(exc.value) == f"{out}: cannot write (Permission denied)"
    assert os.listdir(tmp_path) == []


def test_mkstemp_failure_names_the_output(tmp_path, monkeypatch):
    import tempfile

    def deny(prefix="", suffix="", dir=None):
        raise PermissionError(13, "Permission denied", os.path.join(dir, prefix + "x" + suffix))

    monkeypatch.setattr(tempfile, "mkstemp", deny)
    out = tmp_path / "t.csv"
    with pytest.raises(DataError) as exc:
        write_table(out, {"a": np.arange(3.0)})
    assert str(exc.value) == f"{out}: cannot write (Permission denied)"


def test_output_set_names_the_output_not_its_temporary(tmp_path, monkeypatch):
    """A writer inside an OutputSet (itself atomic: a temporary of a temporary) that fails
    names the command's output (was `ro/..o.92ef.json.tmp: Permission denied`)."""
    out = tmp_path / "o.json"
    outs = OutputSet([out], [])
    _deny_replace(monkeypatch)
    with pytest.raises(DataError) as exc, outs, atomic_open(outs.path(out)) as fh:
        fh.write("{}")
    assert str(exc.value) == f"{out}: cannot write (Permission denied)"
    # an OSError raised by the writer itself (a library writing the temporary directly)
    outs = OutputSet([out], [])
    with pytest.raises(DataError) as exc, outs:
        tmp = outs.path(out)
        raise PermissionError(13, "Permission denied", str(tmp))
    assert str(exc.value) == f"{out}: cannot write (Permission denied)"
    assert not TEMP.search(str(exc.value))
    assert os.listdir(tmp_path) == []


def test_output_set_commit_failure_names_the_output(tmp_path, monkeypatch):
    out = tmp_path / "o.csv"
    outs = OutputSet([out], [])
    with pytest.raises(DataError) as exc, outs:
        outs.path(out).write_text("a\n1\n")
        _deny_replace(monkeypatch)
    assert str(exc.value) == f"{out}: cannot write (Permission denied)"
    assert os.listdir(tmp_path) == []


def test_folder_output_errors_name_the_folder(tmp_path):
    target = tmp_path / "rep"
    outs = OutputSet([], [], folders=[target])
    with pytest.raises(DataError) as exc, outs:
        folder = outs.folder(target)
        raise PermissionError(13, "Permission denied", str(folder / "page.html"))
    assert str(exc.value) == f"{target}/page.html: cannot write (Permission denied)"


def test_cli_error_names_the_output(tmp_path, monkeypatch, write_dataset, op2):
    """`sescid identify data.csv --out ro/o.json` on a folder that refuses the write: one line
    naming ro/o.json, nothing left in the folder."""
    import sescid

    sim = sescid.simulate(op2, 40, noise=0.001, seed=1)
    data = write_dataset(tmp_path / "d.csv", sim.q, sim.cop)
    ro = tmp_path / "ro"
    ro.mkdir()
    _deny_replace(monkeypatch)
    args = ["identify", str(data), "--allow-outside-limits", "--out", str(ro / "o.json")]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2
    assert res.output == f"sescid: error: {ro / 'o.json'}: cannot write (Permission denied)\n"
    assert os.listdir(ro) == []


@pytest.mark.parametrize(
    ("name", "text", "where"),
    [
        (
            "s.json",
            '{"format": "x", "feet": {"right": {"saturation_count": Infinity}}}',
            "feet.right.saturation_count",
        ),
        ("s.json", '{"format": "x", "cells": [1, 1e999]}', "cells.1"),
        ("s.yaml", "format: x\nscale: .inf\n", "scale"),
    ],
)
def test_infinite_numbers_are_refused_with_their_field(tmp_path, name, text, where):
    """`saturation_count: Infinity` in a sensor file was an OverflowError traceback."""
    from sescid.base.files import read_document, read_json

    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(DataError, match=rf"{name}: {re.escape(where)}: -?inf is not a finite"):
        read_document(path)
    if name.endswith(".json"):
        with pytest.raises(DataError, match=re.escape(where)):
            read_json(path, "x", "a test file")


def test_sensor_file_with_infinity_is_one_line(tmp_path, op2):
    """The hostile case through the sensor reader: one line naming the file and the field."""
    from sescid.sensors.pads import load_sensors

    path = tmp_path / "fsr.json"
    path.write_text('{"format": "sescid-fsr/1", "saturation_count": Infinity}')
    with pytest.raises(DataError, match=r"fsr.json: saturation_count: inf is not a finite"):
        load_sensors(path, profile=op2.profile)


def test_a_folder_named_like_the_robot_is_not_an_input(tmp_path, monkeypatch):
    """`--robot op2` (the default) beside a folder called op2: the option names the robot, so
    outputs may go into the folder; a folder given as an input is one."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "op2").mkdir()
    args = ["simulate", "--robot", "op2", "--poses", "3", "--out", "op2/sim.csv"]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    assert (tmp_path / "op2" / "sim.csv").is_file()
    with pytest.raises(DataError, match="inside the input"):
        check_outputs([Path("op2") / "sim.csv"], ["op2"])  # a folder among the inputs
