"""Streamed tables (pyarrow chunks) against the plain csv reader; chunked fit against in-memory."""

from __future__ import annotations

import numpy as np
import pytest
from fitting import identify_ls, identify_stream

from sescid import identify
from sescid.errors import DataError
from sescid.estimation import Measurements
from sescid.simulation import simulate
from sescid.tables import (
    iter_table,
    read,
    read_ahead,
    read_cop,
    read_poses,
    read_table,
    write_table,
)


@pytest.fixture(params=[1, 40])
def small_blocks(monkeypatch, request):
    """Parsed blocks of 4 kB, each its own chunk or joined into chunks of ≥ 40 rows, so a
    small file streams in many chunks."""
    monkeypatch.setattr(read, "CSV_BLOCK_BYTES", 4096)
    monkeypatch.setattr(read, "CSV_CHUNK_ROWS", request.param)


def _columns(op2, n, seed=3):
    sim = simulate(op2, n, seed=seed)
    cols = {name: sim.q[:, j] for j, name in enumerate(op2.joint_names)}
    cols |= {"cop_x": sim.cop[:, 0], "cop_y": sim.cop[:, 1], "pose": np.arange(n)}
    return cols


def test_streamed_csv_equals_plain_reader(op2, tmp_path, small_blocks):
    """Every chunk is bit-exact with the csv-module reader, rows numbered from the file."""
    path = tmp_path / "poses.csv"
    cols = _columns(op2, 400)
    write_table(path, cols)
    chunks = list(iter_table(path))
    assert len(chunks) > 5
    assert all(c.n >= read.CSV_CHUNK_ROWS for c in chunks[:-1])
    plain = read._read_csv_plain(path)
    assert [c.first_row for c in chunks][:2] == [2, 2 + chunks[0].n]
    for name in plain.names():
        joined = np.concatenate([c.columns[name] for c in chunks])
        np.testing.assert_array_equal(joined, plain.columns[name])
        np.testing.assert_array_equal(joined, cols[name])  # lossless round trip
    np.testing.assert_array_equal(read_table(path).columns["cop_x"], cols["cop_x"])


def test_streamed_errors_name_the_file_row(op2, tmp_path, small_blocks):
    """A bad cell far down the file: the same file/row/column message as the plain reader."""
    path = tmp_path / "bad.csv"
    write_table(path, _columns(op2, 300))
    lines = path.read_text().splitlines()
    cells = lines[251].split(",")  # file row 252
    cells[2] = "oops"
    lines[251] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    col = lines[0].split(",")[2]
    with pytest.raises(
        DataError, match=rf"bad\.csv: row 252, column '{col}': 'oops' is not a number"
    ):
        for table in iter_table(path):
            read_poses(table, op2.joint_names)
    lines[100] = lines[100] + ",1"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"bad\.csv: row 101 has 24 fields, the header has 23"):
        list(iter_table(path))


def test_identify_chunks_equals_in_memory(op2, small_blocks, tmp_path):
    """The chunked fit (a streamed file) equals identify_ls on the joined arrays."""
    path = tmp_path / "sim.csv"
    write_table(path, _columns(op2, 5000, seed=4))
    chunks = [(read_poses(t, op2.joint_names), read_cop(t)) for t in iter_table(path)]
    q = np.concatenate([c[0] for c in chunks])
    cop = np.concatenate([c[1] for c in chunks])
    ref = identify_ls(op2, q, cop)
    fit = identify_stream(op2, chunks)
    np.testing.assert_array_equal(fit.r, ref.r)  # same blocks, same sums
    assert fit.mae == pytest.approx(ref.mae, rel=1e-12)
    assert fit.rms == pytest.approx(ref.rms, rel=1e-12)


def test_identify_once_equals_chunks_and_memory(op2, small_blocks, tmp_path):
    """One pass with a spill: the same r bit for bit, MAE/RMS as the chunked and in-memory fits,
    and the noise-free CoP error equal to one computed directly."""
    path = tmp_path / "sim.csv"
    cols = _columns(op2, 3000, seed=5)
    cols["cop_x_true"], cols["cop_y_true"] = cols["cop_x"] + 1e-4, cols["cop_y"] - 2e-4
    write_table(path, cols)
    tables = list(iter_table(path))
    chunks = [(read_poses(t, op2.joint_names), read_cop(t)) for t in tables]
    truth = [np.column_stack([t.get("cop_x_true"), t.get("cop_y_true")]) for t in tables]
    ref = identify_stream(op2, chunks)
    once = (Measurements(q=q, cop=c, cop_true=t) for (q, c), t in zip(chunks, truth, strict=True))
    fit = identify(op2, once, method="ls")
    np.testing.assert_array_equal(fit.r, ref.r)
    assert fit.mae == ref.mae and fit.rms == ref.rms  # same chunks, same sums
    q = np.concatenate([c[0] for c in chunks])
    err = ref.predict_cop(q) - np.concatenate(truth)
    assert fit.truth_cop_rmse == pytest.approx(np.sqrt(np.mean(err**2)), rel=1e-12)


def test_read_ahead_same_chunks_errors_and_early_exit(op2, tmp_path, small_blocks):
    """read_ahead yields the same chunks, raises the reader's error, and stops when left."""
    path = tmp_path / "sim.csv"
    write_table(path, _columns(op2, 6000, seed=6))
    plain = [t.columns["cop_x"] for t in iter_table(path)]
    ahead = [t.columns["cop_x"] for t in read_ahead(iter_table(path))]
    assert len(plain) > 2 and all(np.array_equal(a, b) for a, b in zip(plain, ahead, strict=True))

    def failing():
        yield from iter_table(path)
        raise DataError("boom")

    with pytest.raises(DataError, match="boom"):
        list(read_ahead(failing()))
    for _ in read_ahead(iter_table(path), depth=1):
        break  # leaving early must not hang on the reader thread


def test_json_kinds_are_the_formats_of_the_layers_above(tmp_path):
    """The table reader names a JSON file by its format's name (``JSON_KINDS``, low in the
    layers): those names are the formats the fit, truth, foot-sensor and plate files carry,
    and a file of each is refused as a table in one line naming what it is."""
    import json
    import re

    from sescid.bench.truth import TRUTH_FORMAT
    from sescid.estimation.result.fit_json import FIT_FORMAT
    from sescid.sensors.pads import FSR_FORMAT
    from sescid.sensors.wrench import PLATE_FORMAT
    from sescid.tables.file_kinds import JSON_KINDS

    formats = (FIT_FORMAT, TRUTH_FORMAT, FSR_FORMAT, PLATE_FORMAT)
    assert sorted(JSON_KINDS) == sorted(f.split("/")[0] for f in formats)
    for fmt in formats:
        path = tmp_path / "x.csv"
        path.write_text(json.dumps({"format": fmt}))
        what = f"{JSON_KINDS[fmt.split('/')[0]]}, format {fmt}, not a table"
        with pytest.raises(DataError, match=re.escape(what)):
            read_table(path)
    path.write_text(json.dumps({"format": "other/1"}))
    with pytest.raises(DataError, match=r"a JSON file \(format other/1\), not a table"):
        read_table(path)
