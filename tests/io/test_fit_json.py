"""Tables, fit JSON round trip, atomic writes."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from fitting import identify_ls

import sescid
from sescid import tables
from sescid.base.files import atomic_open
from sescid.simulation import simulate


def test_fit_round_trip(op2, tmp_path):
    sim = simulate(op2, 200, seed=1)
    fit = identify_ls(op2, sim.q, sim.cop)
    path = tmp_path / "fit.json"
    sescid.save_fit(fit, path)
    data = json.loads(path.read_text())
    assert data["format"] == "sescid-fit/3"
    assert data["rank"] == 42 and data["n_poses"] == 200
    assert data["robot"]["source"] == "op2" and data["robot"]["support"] == "r_sole"
    assert data["sigma_hat"] == pytest.approx(fit.sigma_hat)
    assert data["r"]["MP_BODY"] == pytest.approx(fit.r[6].tolist())
    back = sescid.load_fit(path)
    np.testing.assert_array_equal(back.r, fit.r)
    np.testing.assert_array_equal(back.predict_cop(sim.q), fit.predict_cop(sim.q))
    np.testing.assert_allclose(back.predict_std(sim.q[:5]), fit.predict_std(sim.q[:5]))
    assert [c.label() for c in back.base] == [c.label() for c in fit.base]
    assert [c.reason for c in back.unidentifiable] == [c.reason for c in fit.unidentifiable]


def test_load_fit_rejects_other_json(tmp_path):
    path = tmp_path / "x.json"
    path.write_text('{"a": 1}')
    with pytest.raises(sescid.SescidError, match="not a sescid fit"):
        sescid.load_fit(path)
    path.write_text("{nope")
    with pytest.raises(sescid.SescidError, match="not a JSON file"):
        sescid.load_fit(path)
    path.write_text('{"format": "sescid-fit/9"}')
    with pytest.raises(sescid.SescidError, match="format 'sescid-fit/9' is not one this sescid"):
        sescid.load_fit(path)


def test_atomic_open_leaves_nothing_on_error(tmp_path):
    target = tmp_path / "out.csv"
    with pytest.raises(RuntimeError), atomic_open(target) as fh:
        fh.write("half")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    with atomic_open(target) as fh:
        fh.write("ok")
    assert target.read_text() == "ok" and len(list(tmp_path.iterdir())) == 1
    mask = os.umask(0)
    os.umask(mask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~mask  # as open() would create it


def _csv(tmp_path, text: str):
    path = tmp_path / "t.csv"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("a,b\n1,2\n3,x\n", r"row 3, column 'b': 'x' is not a number"),
        ("a,b\n1,2\n3,nan\n", r"row 3, column 'b': value nan is not finite"),
        ("a,b\n1,2\n3\n", r"row 3 has 1 fields, the header has 2"),
        ("a,a\n1,2\n", r"column 'a' appears twice"),
        ("a,b\n", r"no data rows"),
        ("", r"empty file"),
    ],
)
def test_table_errors_name_row_and_column(tmp_path, text, message):
    path = _csv(tmp_path, text)
    with pytest.raises(sescid.SescidError, match=message):
        table = tables.read_table(path)
        table.get("a")
        table.get("b")


def test_read_poses_checks_columns_and_units(op2, tmp_path):
    names = op2.joint_names
    header = ",".join(names)
    row = ",".join(["0.1"] * 20)
    with pytest.raises(sescid.SescidError, match="missing joint column 'head_tilt'"):
        tables.read_poses(
            tables.read_table(_csv(tmp_path, ",".join(names[:-1]) + "\n" + row[4:] + "\n")), names
        )
    deg = ",".join(["0.1"] * 19 + ["30"])
    with pytest.raises(
        sescid.SescidError, match=r"row 3, column 'head_tilt': 30 looks like degrees"
    ):
        tables.read_poses(tables.read_table(_csv(tmp_path, f"{header}\n{row}\n{deg}\n")), names)
    q = tables.read_poses(tables.read_table(_csv(tmp_path, f"{header}\n{row}\n")), names)
    assert q.shape == (1, 20) and q[0, 0] == 0.1


def test_parquet_round_trip(tmp_path):
    cols = {"a": np.arange(5.0), "b": np.linspace(0, 1, 5)}
    tables.write_table(tmp_path / "t.parquet", cols)
    table = tables.read_table(tmp_path / "t.parquet")
    np.testing.assert_array_equal(table.get("b"), cols["b"])


def test_write_table_csv_keeps_full_precision(tmp_path):
    x = np.array([np.pi, -1e-9, 0.1 + 0.2])
    tables.write_table(tmp_path / "t.csv", {"x": x})
    np.testing.assert_array_equal(tables.read_table(tmp_path / "t.csv").get("x"), x)


def test_version_1_fit_files_are_read(tmp_path):
    """A sescid-fit/1 file (results in a free 'extra' object) loads into the typed records."""
    import json

    import sescid
    from sescid.estimation import MapOptions, load_fit, save_fit

    robot = sescid.load_robot("op2")
    sim = sescid.simulate(robot, 60, noise=0.004, seed=3)
    fit = sescid.identify(robot, sim.q, sim.cop, method=MapOptions(bias=True))
    save_fit(fit, tmp_path / "v2.json")
    data = json.loads((tmp_path / "v2.json").read_text())
    v1 = {k: v for k, v in data.items() if k not in ("map", "cop_offset", "weighted")}
    v1["format"] = "sescid-fit/1"
    v1["method"] = "map"
    v1["extra"] = {
        "prior_scale_m": fit.map.prior_scale,
        "prior_scale_chosen_by": "evidence",
        "noise_m": fit.map.noise,
        "noise_chosen_by": "evidence",
        "log_evidence": fit.map.log_evidence,
        "effective_parameters": fit.map.effective_parameters,
        "dof": fit.sigma_dof,
        "bias": fit.cop_offset.value.tolist(),
        "bias_std": fit.cop_offset.std.tolist(),
    }
    (tmp_path / "v1.json").write_text(json.dumps(v1))
    back = load_fit(tmp_path / "v1.json")
    assert back.method == "map" and back.map.prior_scale == fit.map.prior_scale
    assert back.sigma_dof == fit.sigma_dof and back.residual_dof == fit.residual_dof
    assert list(back.cop_offset.value) == list(fit.cop_offset.value)
    q = sim.q[:5]
    assert (back.predict_cop(q) == fit.predict_cop(q)).all()


def test_a_model_edited_after_the_fit_is_flagged(op2, tmp_path):
    """The fit stores the model's total mass and SESC vectors: a model file edited afterwards
    (one body 50 g heavier) is named in a warning of the fit read back; the unedited one is not."""
    import re

    from sescid.estimation import MODEL_CHANGED

    urdf = tmp_path / "robot.urdf"
    urdf.write_text(op2.model_path.read_text())
    robot = sescid.load_robot(str(urdf), op2.support)
    sim = simulate(robot, 100, seed=2)
    path = tmp_path / "fit.json"
    sescid.save_fit(identify_ls(robot, sim.q, sim.cop), path)
    assert not any(w.startswith(MODEL_CHANGED) for w in sescid.load_fit(path).warnings)
    text = urdf.read_text()
    m = re.search(r'<link name="MP_HEAD">.*?<mass value="([0-9.eE+-]+)"', text, re.S)
    assert m is not None
    heavier = f"{float(m.group(1)) + 0.05!r}"
    urdf.write_text(text[: m.start(1)] + heavier + text[m.end(1) :])
    (w,) = [w for w in sescid.load_fit(path).warnings if w.startswith(MODEL_CHANGED)]
    assert f"{robot.total_mass + 0.05:.4g} kg ({robot.total_mass:.4g} kg at fit time)" in w
