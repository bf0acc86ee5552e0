"""A raw log reduced in chunks (``sensors.fsr_chunks``) gives the whole-file reduction, pose for
pose, bit for bit: poses split across chunks, a gantry part before a standing part (the foot
decision made again), rows out of order (reduced whole), and errors naming the file's row."""

from __future__ import annotations

import csv
import dataclasses
import random

import numpy as np
import pytest
from click.testing import CliRunner

from sescid.cli import cli
from sescid.errors import DataError
from sescid.sensors import fsr, fsr_chunks, load_sensors
from sescid.tables import iter_table, read, read_table


@pytest.fixture
def small_chunks(monkeypatch):
    """CSV chunks of ~100 rows (a pose's 30 samples span chunks)."""
    monkeypatch.setattr(read, "CSV_BLOCK_BYTES", 1 << 12)
    monkeypatch.setattr(read, "CSV_CHUNK_ROWS", 100)


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """Raw logs of the kinematic bench: pads; pads, torques and approach sides; a gantry."""
    d = tmp_path_factory.mktemp("logs")
    run = CliRunner()

    def sescid(*args):
        res = run.invoke(cli, [str(a) for a in args])
        assert res.exit_code == 0, res.output

    sescid("poses", "--select", "random", "--count", "24", "--seed", "1", "--out", d / "p.csv")
    sescid("poses", "--select", "random", "--count", "24", "--seed", "2", "--mount", "gantry",
           "--support", "MP_BODY", "--kinds", "tau", "--out", d / "pg.csv")  # fmt: skip
    sescid("experiment", "--poses", d / "p.csv", "--samples", "30", "--out", d / "pads.csv")
    sescid("experiment", "--poses", d / "p.csv", "--samples", "30", "--torques", "all",
           "--friction", "0.01", "0.03", "--out", d / "tau.csv")  # fmt: skip
    sescid("experiment", "--poses", d / "pg.csv", "--samples", "30", "--mount", "gantry",
           "--support", "MP_BODY", "--torques", "all", "--out", d / "gantry.csv")  # fmt: skip
    sescid("experiment", "--poses", d / "p.csv", "--samples", "30", "--torques", "all",
           "--out", d / "tau_plain.csv")  # fmt: skip
    return d


def _rows(path):
    with path.open(newline="") as f:
        r = csv.reader(f)
        return next(r), list(r)


def _write(path, header, rows):
    with path.open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows(rows)
    return path


def _same(a, b):
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if dataclasses.is_dataclass(x):  # the measured quantities (``Measured.data``)
            _same(x, y)
        elif isinstance(x, np.ndarray):
            nan = x.dtype.kind == "f"
            assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=nan), f.name
        else:
            assert x == y, f.name


def _chunked(robot, path, config):
    return fsr_chunks(robot, lambda: iter_table(path), config, whole=lambda: read_table(path))


def _both(robot, path, sensors):
    config = load_sensors(None, robot.profile) if sensors else None
    whole = fsr(robot, read_table(path), config)
    return whole, _chunked(robot, path, config)


@pytest.mark.parametrize("name", ["pads.csv", "tau.csv", "gantry.csv"])
def test_chunks_give_the_whole_files_reduction(robot, logs, small_chunks, name):
    (w, wu), (c, cu) = _both(robot, logs / name, True)
    assert w.mode == c.mode and len(c.pose) > 5
    _same(w, c)
    assert wu == cu


def test_a_gantry_part_before_a_standing_part(robot, logs, small_chunks, tmp_path):
    """Torques with unloaded feet first (reduced on torques alone), then loaded feet: the whole
    log uses its feet, so the first chunks are reduced again with them."""
    hg, g = _rows(logs / "gantry.csv")
    ht, t = _rows(logs / "tau_plain.csv")
    assert hg == ht
    rows = [["g" + r[0], *r[1:]] for r in g] + [["s" + r[0], *r[1:]] for r in t]
    path = _write(tmp_path / "mixed.csv", hg, rows)
    (w, _), (c, _) = _both(robot, path, True)
    assert w.mode == "forces" and any(p.startswith("g") for p, _ in c.dropped)
    _same(w, c)


def test_rows_out_of_order_are_reduced_whole(robot, logs, small_chunks, tmp_path):
    header, rows = _rows(logs / "pads.csv")
    random.Random(0).shuffle(rows)
    path = _write(tmp_path / "shuffled.csv", header, rows)
    (w, _), (c, _) = _both(robot, path, True)
    _same(w, c)


def test_an_error_names_the_files_row(robot, logs, small_chunks, tmp_path):
    header, rows = _rows(logs / "pads.csv")
    rows[250][header.index("r_fsr2")] = "-3"
    path = _write(tmp_path / "bad.csv", header, rows)
    config = load_sensors(None, robot.profile)
    with pytest.raises(DataError, match=r"row 252, column 'r_fsr2': negative force count"):
        _chunked(robot, path, config)


def test_a_dead_torque_sensor_and_a_pose_without_torques_in_chunks(robot, logs, small_chunks,
                                                                     tmp_path):  # fmt: skip
    """A torque column empty throughout is left out once over the whole log (not per chunk:
    the parts would not join), a pose without samples of another joint is dropped with the
    reason, as the whole-file reduction does; an error after a blank line names the file's
    row."""
    header, rows = _rows(logs / "tau.csv")
    dead, part = header.index("tau_r_knee"), header.index("tau_l_hip_roll")
    for r in rows:
        r[dead] = ""
        if r[0] == "5":
            r[part] = ""
    path = _write(tmp_path / "dead.csv", header, rows)
    (w, _), (c, _) = _both(robot, path, True)
    _same(w, c)
    assert "r_knee" not in c.data.tau_joints and "5" not in c.pose.tolist()
    assert any("tau_r_knee" in n for n in c.notes)
    assert any(p == "5" and "tau_l_hip_roll" in why for p, why in c.dropped)
    text = (logs / "pads.csv").read_text().splitlines()
    cells = text[400].split(",")
    cells[text[0].split(",").index("r_fsr2")] = "-3"
    bad = tmp_path / "blank.csv"
    bad.write_text("\n".join([*text[:3], "", *text[3:400], ",".join(cells), *text[401:]]) + "\n")
    with pytest.raises(DataError, match=r"row 402, column 'r_fsr2': negative force count"):
        _chunked(robot, bad, load_sensors(None, robot.profile))
