"""The compiled float formatter against Python's repr (David Gay's dtoa), byte for byte, and the
float64 CSV writer against the csv module's writer and the readers (bit-exact round trips)."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from fitting import identify_ls
from hypothesis import given, settings
from hypothesis import strategies as st

from sescid.simulation import simulate
from sescid.tables import iter_table, read, read_cop, read_poses, read_table, write, write_table
from sescid.tables.float_text import format_rows


def float_text(values: np.ndarray) -> list[str]:
    """Each float64 of ``values`` (any shape, flattened) as the compiled formatter's text."""
    flat = np.ascontiguousarray(values, dtype=np.float64).reshape(-1, 1)
    return format_rows(flat).tobytes().decode("ascii").splitlines()


def _reference(values) -> list[str]:
    return [repr(float(v)) for v in np.asarray(values, dtype=float).ravel()]


def _assert_bit_exact(text: list[str], values) -> None:
    back = np.array([float(t) for t in text])
    want = np.asarray(values, dtype=float).ravel()
    np.testing.assert_array_equal(back.view(np.uint64), want.view(np.uint64))


def test_edge_values_are_written_as_repr():
    """Zeros, signs, nan/inf, subnormals, extremes and the fixed/exponent switch points."""
    values = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.1,
        0.3,
        2 / 3,
        1e-4,
        1e-5,
        9.999999999999999e-5,
        1e15,
        1e16,
        9999999999999998.0,
        1.5e16,
        123456789012345678.0,
        1e22,
        1e23,
        2.0**53 + 2,
        5e-324,
        -5e-324,
        2.2250738585072009e-308,  # largest subnormal
        2.2250738585072014e-308,  # smallest normal
        1.7976931348623157e308,
        -1.7976931348623157e308,
        math.inf,
        -math.inf,
    ]
    assert float_text(np.array(values)) == _reference(values)
    nans = np.array(
        [math.nan, -math.nan, struct.unpack("<d", b"\x01\x00\x00\x00\x00\x00\xf8\xff")[0]]
    )
    assert float_text(nans) == ["nan", "nan", "nan"]


def test_every_binary_exponent_and_power_of_ten():
    """2^e for every e of float64 (and the doubles beside each), 10^k for every k: as repr."""
    twos = np.ldexp(1.0, np.arange(-1074, 1024))
    near = np.concatenate([twos, np.nextafter(twos, 0), np.nextafter(twos, np.inf)])
    near = near[np.isfinite(near)]
    tens = np.array([float(f"1e{k}") for k in range(-323, 309)])
    values = np.concatenate([near, -near, tens, np.nextafter(tens, 0), np.arange(-2000.0, 2000.0)])
    assert float_text(values) == _reference(values)


def test_random_bit_patterns_as_repr():
    """100 000 uniformly random 64-bit patterns (every exponent, nan payloads): as repr."""
    bits = np.random.default_rng(8).integers(0, 2**64, size=100_000, dtype=np.uint64)
    values = bits.view(np.float64)
    text = float_text(values)
    assert text == _reference(values)
    finite = np.isfinite(values)
    _assert_bit_exact([t for t, f in zip(text, finite, strict=True) if f], values[finite])


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True), max_size=40))
def test_any_float_reads_back_bit_exact(values):
    """Hypothesis over floats (subnormals, huge, −0.0, integers): repr's text, float(text) exact."""
    text = float_text(np.array(values, dtype=float))
    assert text == [repr(float(v)) for v in values]
    keep = [i for i, v in enumerate(values) if not math.isnan(v)]
    _assert_bit_exact([text[i] for i in keep], [values[i] for i in keep])


def test_format_rows_is_csv_rows():
    """Commas between the numbers of a row, a newline after each row."""
    x = np.array([[1.0, -0.5, 1e-7], [2.5, 0.0, -3e20]])
    assert format_rows(x).tobytes() == b"1.0,-0.5,1e-07\n2.5,0.0,-3e+20\n"
    assert format_rows(np.zeros((0, 3))).tobytes() == b""


def test_float_csv_equals_the_csv_module_writer(tmp_path, monkeypatch):
    """The threaded float64 writer (many small blocks) writes the csv module's bytes, reread
    bit for bit by both readers."""
    monkeypatch.setattr(write, "WRITE_BLOCK_ROWS", 7)
    monkeypatch.setattr(write, "PYTHON_WRITE_NUMBERS", 0)  # the compiled path, however small
    rng = np.random.default_rng(2)
    cols = {
        "a": rng.normal(size=101),
        "b,quoted": rng.normal(size=101) * 1e-6,
        "c": np.round(rng.normal(size=101) * 1e3),
        "d": (rng.integers(0, 2**64, size=101, dtype=np.uint64)).view(np.float64),
    }
    cols["d"][~np.isfinite(cols["d"])] = 1.0
    fast, plain = tmp_path / "fast.csv", tmp_path / "plain.csv"
    write_table(fast, cols)
    write._write_csv_plain(plain, list(cols), list(cols.values()))
    assert fast.read_bytes() == plain.read_bytes().replace(b"\r\n", b"\n")
    for table in (read_table(fast), read._read_csv_plain(fast)):
        for name, values in cols.items():
            np.testing.assert_array_equal(
                table.columns[name].view(np.uint64), values.view(np.uint64)
            )


def test_small_table_in_python_same_bytes(tmp_path, monkeypatch):
    """A small table written without numba (Python's repr) has the compiled formatter's bytes."""
    x = np.random.default_rng(5).normal(size=(40, 5)) * np.logspace(-8, 8, 5)
    x[0] = [0.0, -0.0, 1.0, 5e-324, 1e16]
    cols = {f"c{j}": x[:, j] for j in range(5)}
    monkeypatch.setattr(write, "_small_write", lambda numbers: True)
    small, big = tmp_path / "small.csv", tmp_path / "big.csv"
    write_table(small, cols)
    monkeypatch.setattr(write, "_small_write", lambda numbers: False)
    write_table(big, cols)
    assert small.read_bytes() == big.read_bytes()
    assert small.read_bytes().split(b"\n", 1)[1] == format_rows(x).tobytes()


def test_simulated_file_round_trip_and_fit(op2, tmp_path, monkeypatch):
    """A simulate-style file: every number reread bit for bit in streamed chunks, and the fit
    of the file is the in-memory fit of the same arrays, bit for bit."""
    monkeypatch.setattr(write, "WRITE_BLOCK_ROWS", 500)
    monkeypatch.setattr(read, "CSV_BLOCK_BYTES", 1 << 16)
    monkeypatch.setattr(read, "CSV_CHUNK_ROWS", 1)
    sim = simulate(op2, 3000, seed=11)
    cols = {name: sim.q[:, j] for j, name in enumerate(op2.joint_names)}
    cols |= {"cop_x": sim.cop[:, 0], "cop_y": sim.cop[:, 1]}
    path = tmp_path / "sim.csv"
    write_table(path, cols)
    chunks = list(iter_table(path))
    assert len(chunks) > 2
    q = np.concatenate([read_poses(t, op2.joint_names) for t in chunks])
    cop = np.concatenate([read_cop(t) for t in chunks])
    np.testing.assert_array_equal(q.view(np.uint64), sim.q.view(np.uint64))
    np.testing.assert_array_equal(cop.view(np.uint64), sim.cop.view(np.uint64))
    assert path.read_text().splitlines()[0] == ",".join(cols)
    np.testing.assert_array_equal(identify_ls(op2, q, cop).r, identify_ls(op2, sim.q, sim.cop).r)


@pytest.mark.parametrize("dtype", [np.float32, np.int64])
def test_other_number_columns_keep_their_writer(tmp_path, dtype):
    """float32 and integer columns still go through pyarrow's writer (their own shortest form)."""
    path = tmp_path / "t.csv"
    values = np.array([1, 2, 300], dtype=dtype) / (3 if dtype == np.float32 else 1)
    write_table(path, {"x": values.astype(dtype), "y": np.array([0.5, 0.25, 0.125])})
    back = read_table(path).columns["x"]
    np.testing.assert_array_equal(back.astype(dtype), values.astype(dtype))


@pytest.mark.parametrize("small", [True, False])
def test_no_rows_header_only(tmp_path, monkeypatch, small):
    """Float columns of no rows: the header alone, by either path."""
    monkeypatch.setattr(write, "_small_write", lambda numbers: small)
    path = tmp_path / "empty.csv"
    write_table(path, {"a": np.zeros(0), "b": np.zeros(0)})
    assert path.read_bytes() == b"a,b\n"


def test_text_beside_numbers_is_written_as_the_csv_module_writes_it(tmp_path):
    """A table with text columns beside float runs (simulate's ``support``, measure's pose ids)
    is written by the compiled formatter, byte for byte the csv module's file: floats of every
    kind (nan, ±inf, −0.0, subnormal, huge), integer (int64's whole range, uint8) and bool
    columns, text that needs quoting (commas, quotes, line breaks), empty cells; over several
    blocks; a text column of one value in some blocks and two in another, and a float32 column
    whose −0.0 and 0.0 are equal numbers but different cells."""
    from sescid.tables import write

    rng = np.random.default_rng(5)
    n = 2 * write.WRITE_BLOCK_ROWS + 7
    special = np.array([np.nan, np.inf, -np.inf, -0.0, 5e-324, 1.7976931348623157e308, 0.1])
    a = rng.standard_normal(n) * 10.0 ** rng.integers(-12, 12, n)
    a[: len(special)] = special
    words = np.array(["r_sole", 'say "hi"', "a,b", "two\nlines", "", "l_sole"], dtype=object)
    cols = {
        "pose": np.array([f"p{i}" for i in range(n)]),
        "x": a,
        "y": rng.standard_normal(n),
        "support": words[rng.integers(0, len(words), n)],
        "k": rng.integers(-5, 5, n),
        "flag": rng.integers(0, 2, n).astype(bool),
        "z": rng.standard_normal(n),
        "stance": np.where(np.arange(n) < write.WRITE_BLOCK_ROWS + 3, "r_sole", "l_sole"),
        "foot": words[rng.integers(0, len(words), n)].astype(str),
        "one": np.full(n, 7),
        "wide": rng.integers(np.iinfo(np.int64).min, np.iinfo(np.int64).max, n, endpoint=True),
        "u8": rng.integers(0, 256, n).astype(np.uint8),
        "f32": np.where(rng.integers(0, 2, n) == 1, -0.0, 0.0).astype(np.float32),
        "raw": np.full(n, b"a,b"),
    }
    names, arrays = list(cols), [np.asarray(v) for v in cols.values()]
    write._write_csv_plain(tmp_path / "plain.csv", names, arrays)
    write._write_csv_mixed(tmp_path / "mixed.csv", names, arrays)
    assert (tmp_path / "mixed.csv").read_bytes() == (tmp_path / "plain.csv").read_bytes()
