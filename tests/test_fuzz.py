"""Fuzzing every reader: any file gives a result or a SescidError, never another exception.

Each reader gets valid seed files mutated byte by byte (deletions, insertions, replacements,
truncation, duplicated chunks) by hypothesis: a few dozen examples per reader in the default
run, many more under ``-m slow``.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import sescid
from sescid.errors import SescidError

FAST, SLOW = 15, 400
TOKENS = [b",", b"\n", b'"', b"nan", b"inf", b"1e999", b"-", b"<", b">", b"/>", b"{", b"}",
          b"null", b"\xef\xbb\xbf", b"\xff", b"\x00", b"0", b"9" * 40, b" ", b":"]  # fmt: skip


@st.composite
def mutations(draw):
    """A list of (kind, position in [0, 1), payload) byte edits."""
    ops = st.tuples(
        st.sampled_from(["delete", "insert", "replace", "truncate", "repeat"]),
        st.floats(0, 1, exclude_max=True),
        st.one_of(st.sampled_from(TOKENS), st.binary(min_size=1, max_size=8)),
    )
    return draw(st.lists(ops, min_size=1, max_size=6))


def mutate(data: bytes, ops) -> bytes:
    """Apply byte edits to ``data``."""
    for kind, where, payload in ops:
        i = int(where * (len(data) + 1))
        if kind == "delete":
            data = data[:i] + data[i + 1 + len(payload) :]
        elif kind == "insert":
            data = data[:i] + payload + data[i:]
        elif kind == "replace":
            data = data[:i] + payload + data[i + len(payload) :]
        elif kind == "truncate":
            data = data[:i]
        else:
            data = data[:i] + data[i : i + 64] * 3 + data[i:]
    return data


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    """One valid file per reader, as bytes, with its suffix and the reader."""
    from sescid.io.bags import load_mapping
    from sescid.sensors import fsr as run_fsr
    from sescid.sensors import load_sensors
    from sescid.tables import read_cop, read_poses, read_table, write_table

    d = tmp_path_factory.mktemp("seeds")
    robot = sescid.load_robot("op2")
    sim = sescid.simulate(robot, n=30, range_deg=10, seed=0, clip=True)
    cols = {n: sim.q[:, j] for j, n in enumerate(robot.joint_names)}
    cols |= {"cop_x": sim.cop[:, 0], "cop_y": sim.cop[:, 1]}
    write_table(d / "d.csv", cols)
    write_table(d / "d.parquet", cols)
    fit = sescid.identify(robot, sim.q, sim.cop)
    sescid.save_fit(fit, d / "fit.json")
    prof = robot.profile
    sensors = load_sensors(None, prof)
    pose = np.repeat(np.arange(3), 6)  # a raw log by hand: 3 poses × 6 samples, right foot
    raw = {"pose": pose} | {n: np.zeros(18) for n in robot.joint_names}
    raw |= {f"r_fsr{k}": 7000.0 + 100 * k + pose for k in range(1, 5)}
    raw |= {f"l_fsr{k}": np.zeros(18) for k in range(1, 5)}
    write_table(d / "raw.csv", raw)
    fsr_json = Path(sescid.__file__).parent / "robots" / "op2" / "op2_fsr.json"
    urdf = Path(sescid.__file__).parent / "robots" / "op2" / "op2.urdf"
    from mjcf_gen import random_mjcf

    mjcf_text, frames = random_mjcf(3, n_bodies=4)

    def table_reader(path):
        t = read_table(path)
        read_poses(t, robot.joint_names, prof.servo)
        return read_cop(t)

    readers = {
        "csv": ((d / "d.csv").read_bytes(), ".csv", table_reader),
        "parquet": ((d / "d.parquet").read_bytes(), ".parquet", table_reader),
        "fit": ((d / "fit.json").read_bytes(), ".json", sescid.load_fit),
        "urdf": (urdf.read_bytes(), ".urdf", lambda p: sescid.load_robot(str(p), "r_sole")),
        "mjcf": (mjcf_text.encode(), ".xml", lambda p: sescid.load_robot(str(p), frames[0])),
        "raw": (
            (d / "raw.csv").read_bytes(),
            ".csv",
            lambda p: run_fsr(robot, read_table(p), sensors, 2, None),
        ),
        "sensors": (fsr_json.read_bytes(), ".json", lambda p: load_sensors(p, prof)),
        "bag_mapping": (
            (Path(__file__).parent.parent / "examples" / "bag_mapping.yaml").read_bytes(),
            ".yaml",
            load_mapping,
        ),
    }
    return readers


def _check(seeds, name, ops):
    data, suffix, reader = seeds[name]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"f{suffix}"
        path.write_bytes(mutate(data, ops))
        try:
            reader(path)
        except SescidError:
            pass


READERS = ["csv", "parquet", "fit", "urdf", "mjcf", "raw", "sensors", "bag_mapping"]
_SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@pytest.mark.parametrize("name", READERS)
@settings(max_examples=FAST, **_SETTINGS)
@given(ops=mutations())
def test_reader_gives_a_result_or_a_sescid_error(seeds, name, ops):
    """Mutated files: a result or a SescidError (a few dozen examples per reader)."""
    _check(seeds, name, ops)


@pytest.mark.slow
@pytest.mark.parametrize("name", READERS)
@settings(max_examples=SLOW, **_SETTINGS)
@given(ops=mutations())
def test_reader_fuzz_long(seeds, name, ops):
    """The same with many more examples per reader."""
    _check(seeds, name, ops)


@settings(max_examples=FAST, **_SETTINGS)
@given(
    value=st.one_of(
        st.none(),
        st.booleans(),
        st.floats(allow_nan=True, allow_infinity=True),
        st.text(max_size=5),
        st.lists(st.floats(), max_size=4),
        st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
    ),
    key=st.integers(0, 10_000),
)
def test_fit_json_fields_of_any_type(seeds, value, key):
    """A fit JSON with any one field replaced by any JSON value loads or is a SescidError."""
    data = json.loads(seeds["fit"][0])
    paths = []

    def walk(node, trail):
        paths.append(trail)
        if isinstance(node, dict):
            for k, v in node.items():
                walk(v, (*trail, k))
        elif isinstance(node, list) and node:
            walk(node[0], (*trail, 0))

    walk(data, ())
    trail = paths[key % len(paths)]
    if not trail:
        return
    node = data
    for k in trail[:-1]:
        node = node[k]
    node[trail[-1]] = value
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fit.json"
        path.write_text(json.dumps(data))
        try:
            fit = sescid.load_fit(path)
        except SescidError:
            return
        q = np.zeros((2, fit.robot.nq))
        fit.predict_cop(q)


@pytest.mark.parametrize("name", READERS)
def test_seed_files_are_read(seeds, name):
    """The unmutated seed of each reader gives a result (the fuzzing starts from valid input)."""
    data, suffix, reader = seeds[name]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"f{suffix}"
        path.write_bytes(data)
        assert reader(path) is not None
