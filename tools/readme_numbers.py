"""Run the README's walk-through verbatim and print the figures its table quotes.

    python tools/readme_numbers.py            # prints the table and the truth sentence
    make docs                                  # the same
    python tools/readme_numbers.py --engine mujoco   # the physics bench's row and figures

Runs ``poses → experiment → fsr → identify → report → truth`` (the commands of the README's
"On a real OP2" section) in a temporary folder through the ``sescid`` command line. The table's
residuals are the ones ``sescid report`` computes and prints (``sescid.report``'s numbers on the
file it read: with the file's gravity columns on the physics bench), the truth figures
``sescid truth``'s; the test checks the report's printed line holds them too.
``tests/test_readme_numbers.py`` (slow) checks that the docs quote exactly these strings.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

#: the README's walk-through, verbatim
COMMANDS = [
    "sescid poses --robot op2 --count 38 --select d-optimal --seed 0 --out poses.csv",
    "sescid experiment --robot op2 --poses poses.csv --samples 100 --seed 0 --out raw.csv "
    "--truth truth.json",
    "sescid measure raw.csv --robot op2 --poses poses.csv --out measured.csv",
    "sescid identify measured.csv --robot op2 --weighted --out fit.json",
    "sescid report fit.json measured.csv --out-dir report/",
    "sescid truth fit.json truth.json",
]


def commands(engine: str = "kinematic") -> list[str]:
    """The walk-through, with ``--engine mujoco`` on the experiment line for the physics bench."""
    if engine == "kinematic":
        return list(COMMANDS)
    return [f"{c} --engine {engine}" if c.startswith("sescid experiment ") else c for c in COMMANDS]


def walk_through(engine: str = "kinematic") -> dict[str, str]:
    """Run the commands in a temporary folder; the quoted figures as the README prints them."""
    from click.testing import CliRunner

    from sescid.bench import compare_truth
    from sescid.cli import cli
    from sescid.estimation import load_fit
    from sescid.report import in_unit, read_report_data, with_unit
    from sescid.report.numbers import CAD, IDENTIFIED, cop_numbers
    from sescid.tables import read_cop, read_poses, read_table

    here = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)
        try:
            start = time.perf_counter()
            printed = {}
            for line in commands(engine):
                res = CliRunner().invoke(cli, line.split()[1:])
                if res.exit_code != 0:
                    raise SystemExit(f"{line}: exit {res.exit_code}\n{res.output}")
                printed[line.split()[1]] = res.output
            seconds = time.perf_counter() - start
            fit = load_fit("fit.json")
            table = read_table("measured.csv")
            q = read_poses(table, fit.robot.joint_names, fit.robot.profile.servo)
            cop = read_cop(table)
            data, _ = read_report_data("measured.csv", fit)  # as `sescid report` reads it
            numbers = cop_numbers(fit, data)
            assert numbers is not None
            truth = compare_truth(fit, "truth.json")
            extra = _physics_figures(fit, table, q, cop) if engine == "mujoco" else {}
        finally:
            os.chdir(here)

    def mm(x: float, digits: int = 2) -> str:
        return f"{x * 1e3:.{digits}f} mm"

    def mean(model: str) -> str:  # as the report prints a model's mean residual per axis
        s = numbers.stats[model]
        return f"({in_unit(s[0].mean, 'm')}, {in_unit(s[1].mean, 'm')}) mm"

    quoted = {
        "manufacturer mean": mean(CAD),
        "manufacturer RMS": with_unit(numbers.total(CAD).rms, "m"),
        "identified mean": mean(IDENTIFIED),
        "identified RMS": with_unit(numbers.total(IDENTIFIED).rms, "m"),
        "identified MAE": with_unit(numbers.total(IDENTIFIED).mae, "m"),
    }
    said = printed["report"]  # the report's own line holds every one of them
    missing = [k for k, v in quoted.items() if v not in said]
    if missing:
        raise SystemExit(f"sescid report printed other figures ({missing}):\n{said}")
    return (
        quoted
        | {
            "residual scale": f"{fit.sigma_hat:.2f}",
            "truth identified": mm(truth.rms_identified),
            "truth manufacturer": mm(truth.rms_manufacturer),
            "fresh identified": mm(truth.fresh_identified),
            "fresh manufacturer": mm(truth.fresh_manufacturer),
            "true mass": f"{truth.true_mass_kg:.3f} kg",
            "model mass": f"{truth.model_mass_kg:.3f} kg",
            "seconds": f"{seconds:.0f}",
        }
        | extra
    )


def _physics_figures(fit, table, q, cop) -> dict[str, str]:
    """Physics bench only: statics vs the pads' CoP, gravity's share, LS vs MAP CoM height."""

    import numpy as np

    from sescid import identify
    from sescid.bench import load_truth
    from sescid.estimation.result.tilt import tilt_direction
    from sescid.sensors.imu import table_gravity
    from sescid.tables import read_cop_se

    t = load_truth("truth.json")
    assert t.physics is not None and t.cop_true is not None
    pads, grav = np.array(t.physics.cop_pads), np.array(t.physics.cop_gravity)
    flat = np.array(t.cop_true)
    robot = fit.robot
    r_true = t.r_true
    qa = np.array(t.q_actual)
    g = table_gravity(robot, table, q)
    se = read_cop_se(table)
    com_true = robot.com(qa, r_true)[:, 2]
    out = {
        "skipped": str(len(t.skipped)),
        "pads − gravity-aware statics max": f"{np.abs(pads - grav).max() * 1e6:.1f} µm",
        "pads − flat statics max": f"{np.abs(pads - flat).max() * 1e3:.2f} mm",
        "pads − flat statics RMS": f"{np.sqrt(np.mean((pads - flat) ** 2)) * 1e3:.2f} mm",
        "foot tilt max": f"{max(t.physics.foot_tilt) * 1e3:.1f} mrad",
        "servo sag max": f"{np.abs(np.array(t.physics.servo_sag)).max() * 1e3:.1f} mrad",
    }
    for label, method, grav_cols in (
        ("flat LS", "ls", None),
        ("gravity LS", "ls", g),
        ("gravity MAP", "map", g),
    ):
        f = identify(robot, q, cop, sigma=se, method=method, gravity=grav_cols)
        d = f.predict_cop(qa) - flat
        dz = f.predict_com(qa)[:, 2] - com_true
        td = tilt_direction(f)
        out[f"{label} truth CoP RMS"] = f"{np.sqrt(np.mean(d**2)) * 1e3:.2f} mm"
        out[f"{label} CoM height RMS"] = f"{np.sqrt(np.mean(dz**2)) * 1e3:.1f} mm"
        out[f"{label} rank"] = str(f.rank)
        if td is not None:
            out[f"{label} height offset"] = (
                f"{td.value * 1e3:.1f} ± {td.std * 1e3:.1f} mm (prior {td.prior * 1e3:.1f} mm)"
            )
    return out


def main() -> None:
    """Print the README's table and truth sentence from a fresh run (``--engine mujoco``: the
    physics bench's row and figures)."""
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", choices=["kinematic", "mujoco"], default="kinematic")
    engine = ap.parse_args().engine
    rows = TABLE_ROWS if engine == "kinematic" else TABLE_ROWS_MUJOCO
    m = walk_through(engine)
    if engine == "kinematic":
        print(TABLE_HEAD)
    for label, model in rows:
        print(f"| {label} | {m[f'{model} mean']} | {m[f'{model} RMS']} |")
    print()
    for key, value in m.items():
        print(f"{key}: {value}")


#: the table's head and rows (label, model) as docs/walkthrough.md shows them
TABLE_HEAD = (
    "| CoP residual, measured − predicted (as `sescid report` prints it), 38 poses | mean (x, y) "
    "| RMS |\n|---|---|---|"
)
TABLE_ROWS = [
    ("manufacturer model", "manufacturer"),
    ("identified (`identify --weighted`: method auto, MAP here)", "identified"),
]
TABLE_ROWS_MUJOCO = [
    ("physics bench (`--engine mujoco`, 38 poses), manufacturer", "manufacturer"),
    ("physics bench (`--engine mujoco`, 38 poses), identified", "identified"),
]


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "src"))
    main()
