"""docs/io.md says what the code does: its mapping examples load, its messages are the code's."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from sescid.io.export.inertia import mass_warnings

DOC = Path(__file__).resolve().parents[2] / "docs" / "io.md"


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", DOC.read_text(), re.S)


def test_mapping_examples_load(tmp_path):
    pytest.importorskip("ruamel.yaml")
    from sescid.io.bags import load_mapping

    blocks = _blocks("yaml")
    assert len(blocks) == 2
    for k, text in enumerate(blocks):
        (tmp_path / f"m{k}.yaml").write_text(text)
        mp = load_mapping(tmp_path / f"m{k}.yaml")
        assert mp.torques is not None
    g1 = load_mapping(tmp_path / "m1.yaml")
    assert g1.feet == () and g1.clock == "/lowstate" and g1.torques.field == "motor_state.tau_est"
    assert g1.joints.index["waist_yaw_joint"] == 12 and len(g1.torques.index) == 13


def test_documented_messages(tmp_path, op2):
    """The table error and the mass warning quoted in the page are the code's."""
    from sescid.tables import read_cop, read_table

    (tmp_path / "measured.csv").write_text("cop_x,cop_y\n" + "0,0\n" * 5 + '"1,5",0\n')
    with pytest.raises(Exception) as exc:
        read_cop(read_table(tmp_path / "measured.csv"))
    line = f"{tmp_path / 'measured.csv'}: row 7, column 'cop_x': '1,5' is not a number"
    assert str(exc.value) == line
    assert "measured.csv: row 7, column 'cop_x': '1,5' is not a number" in DOC.read_text()
    masses = np.array([b.mass for b in op2.model.bodies])
    masses[op2.body_names.index("MP_HEAD")] *= 3.34
    (warning,) = mass_warnings(op2.model, masses)
    quoted = re.search(r"`sescid: warning: (body MP_HEAD: [^`]*?) …`", DOC.read_text()).group(1)
    assert warning.startswith(quoted)
