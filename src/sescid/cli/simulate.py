"""``sescid simulate``: random poses and the CoP they give, with noise (paper §3)."""

from __future__ import annotations

from typing import Literal

import click
import numpy as np

from sescid.base import OutputSet, listed
from sescid.bench import ExperimentConfig, real_robot
from sescid.cli import common
from sescid.cli.flags import flags, record
from sescid.errors import OptionError
from sescid.kinds import BALANCE, COP, TORQUE, DesignKind, Kinds, parse_kinds
from sescid.robot import Robot
from sescid.simulation import PAPER_NOISE, PAPER_POSES, PAPER_RANGE_DEG, TorqueNoise

#: what ``simulate`` measures, as ``--measure`` spells it: a design's kinds, or the balancing
#: tilts of a robot on a line
Measure = Literal[DesignKind, "balance"]


@click.command()
@common.robot_options
@common.study_options(PAPER_POSES, PAPER_RANGE_DEG, PAPER_NOISE)
@common.seed_option
@click.option(
    "--clip/--no-clip",
    default=None,
    help="Clip the poses to the joint limits [default: clip, except for a robot whose profile "
    "carries the paper's convention (op2: the paper's ±30° study is unclipped)].",
)
@click.option("--stable", is_flag=True, help="Keep only poses whose CoP is inside the sole.")
@common.number_option(
    "--tilt-deg", 0.0, 0, 30,
    "Tilt the support per pose by a random roll and pitch of this standard deviation "
    "[degrees]; writes grav_x, grav_y, grav_z.",
)  # fmt: skip
@common.choice_option(
    "--measure",
    Measure,
    None,
    "What the robot measures: the CoP under its foot, its joint torques, or both; "
    "balance: balanced poses of a robot on its support line (--line), read by an IMU "
    "[default: balance on a line support, else cop].",
)
@common.number_option(
    "--tilt-noise-deg", 0.5, 0, 20,
    "--measure balance: error of each pose's measured tilt (the IMU) [degrees].",
)  # fmt: skip
@flags(TorqueNoise, "noise", "offset", "friction")
@flags(ExperimentConfig, "extra_mass_fraction")
@common.file_option("--out", "Output CSV.", required=True)
@common.force_option
def simulate(robot_name, support, poses, range_deg, noise, seed, clip, stable, tilt_deg, out,
             force, **kinds):  # fmt: skip
    """Simulate poses and what a robot measures there (paper §3) into a CSV.

    Columns: one per joint (radians); cop_x, cop_y (noisy, m), cop_x_true, cop_y_true (m); with
    --measure tau or both, tau_<joint> (N·m, noisy, with the sensor offsets and friction) and
    true_tau_<joint>; with --tilt-deg also grav_x, grav_y, grav_z (gravity, support frame).
    A robot balancing on a line (--line; --measure balance): joints, grav_x/y/z (the measured
    gravity direction of each balanced pose) and balance_tilt_true [rad]. Every file has a
    support column (the stance: files of several stances pool in identify).

    The CoP, torques and balance are those of a robot that differs from its model as the
    bench's does (--extra-mass: 7 % of unmodelled mass, placed as `experiment` places it), so a
    fit has something to identify; --extra-mass 0 simulates the model itself (every fit then
    keeps it).
    """
    import dataclasses
    import math

    from sescid.simulation import simulate as run_simulate
    from sescid.tables import write_table

    outs = OutputSet([out], [common.model_input(robot_name)], force=force)
    robot = common.load(robot_name, support)
    measure = kinds["measure"] or ("balance" if robot.line is not None else "cop")
    if robot.line is not None and measure != "balance":  # identify could not read the file
        raise OptionError(
            "measure",
            f"{measure}: a robot balancing on its line (--line) is measured by its balance "
            "(--measure balance): it stands on no sole (no CoP), and its joint torques depend "
            "on the tilt that balances each pose, which this simulation does not write",
        )
    measured = parse_kinds(measure, "measure", Measure)
    common.refuse_idle(("tau_noise", "tau_offset", "tau_friction"), TORQUE in measured,
                f"with --measure {measure}")  # fmt: skip
    common.refuse_idle("noise", COP in measured, f"with --measure {measure} (no CoP)")
    common.refuse_idle("tilt_noise_deg", BALANCE in measured, f"with --measure {measure}")
    r_true, true_mass, placed = real_robot(
        robot, ExperimentConfig(extra_mass_fraction=kinds["extra_mass"])
    )
    if BALANCE in measured:
        from sescid.simulation import simulate_balance

        noise_deg = kinds["tilt_noise_deg"]
        balanced = simulate_balance(robot, poses, range_deg, math.radians(noise_deg), seed, r_true)
        with outs:
            write_table(outs.path(out), _columns(robot, balanced, measured))
        click.echo(f"wrote {out}: {poses} balanced poses of {robot.name} on its line, tilt "
                   f"noise {noise_deg:g}°")  # fmt: skip
        click.echo(f"  {_real_line(robot, true_mass, placed)}")
        return
    sensors = torque_noise(kinds)
    if sensors is not None and sensors.total_mass is None:
        sensors = dataclasses.replace(sensors, total_mass=true_mass)
    sim = run_simulate(
        robot, poses, range_deg, noise, seed, clip, stable=stable, tilt=math.radians(tilt_deg),
        torques=sensors, r_true=r_true,
    )  # fmt: skip
    with outs:
        write_table(outs.path(out), _columns(robot, sim, measured))
    what = ", ".join(
        ([f"CoP noise {noise} m"] if COP in measured else [])
        + ([f"torque noise {kinds['tau_noise']} N·m"] if TORQUE in measured else [])
    )
    click.echo(f"wrote {out}: {poses} poses of {robot.name}, {what}")
    click.echo(f"  {_real_line(robot, true_mass, placed)}")
    if clip is None:
        clip = robot.profile.paper_limits_file is None  # as simulate() resolved it
    if clip:
        click.echo(f"  clipped to the joint limits: {sim.n_clipped} of {poses} poses")
    else:
        lim = robot.joint_limits
        out_of = int(np.sum(np.any((sim.q < lim[:, 0]) | (sim.q > lim[:, 1]), axis=1)))
        click.echo(f"  not clipped: {out_of} of {poses} poses exceed a joint limit")
    if stable:
        click.echo(
            f"  --stable: {sim.n_drawn - poses} of {sim.n_drawn} draws rejected "
            f"(CoP outside the sole {robot.sole.size[0]:.3f} x {robot.sole.size[1]:.3f} m)"
        )


def _real_line(robot: Robot, true_mass: float, placed: list[dict]) -> str:
    """What the simulated robot is: the model, or the model plus its unmodelled masses."""
    import math

    if not placed or math.isclose(true_mass, robot.total_mass, rel_tol=1e-12):
        return (
            f"the robot simulated is the model itself ({robot.total_mass:.4f} kg, "
            "--extra-mass 0): a fit can only keep it"
        )
    where = listed(f"{p['body']} {p['mass_kg'] * 1e3:.0f} g" for p in placed)
    return (
        f"real robot: the model ({robot.total_mass:.4f} kg) plus "
        f"{true_mass - robot.total_mass:.4f} kg it lacks ({where}); the *_true columns are its "
        "noise-free values (--extra-mass 0: the model itself)"
    )


def torque_noise(kinds: dict) -> TorqueNoise | None:
    """The torque sensors' errors from the flags (None when only the CoP is measured)."""
    if kinds["measure"] is None or TORQUE not in parse_kinds(kinds["measure"], "measure", Measure):
        return None
    return record(TorqueNoise, kinds)


def _columns(robot: Robot, sim, measured: Kinds) -> dict[str, np.ndarray]:
    """The written table: joints (rad), what is measured (noisy and true), gravity (measured,
    with --measure balance: of each balanced pose, then its true tilt), the stance (for
    pooling); ``sim`` a ``SimData`` or a ``BalanceData``."""
    cols = {name: sim.q[:, j] for j, name in enumerate(robot.joint_names)}
    if COP in measured:
        cols |= {"cop_x": sim.cop[:, 0], "cop_y": sim.cop[:, 1]}
        cols |= {"cop_x_true": sim.cop_true[:, 0], "cop_y_true": sim.cop_true[:, 1]}
    if TORQUE in measured and sim.torques is not None:
        t = sim.torques
        cols |= {f"tau_{j}": t.tau[:, k] for k, j in enumerate(t.joints)}
        cols |= {f"true_tau_{j}": t.tau_true[:, k] for k, j in enumerate(t.joints)}
        if t.approach is not None:
            cols["approach"] = t.approach
    if sim.gravity is not None:
        cols |= {f"grav_{a}": sim.gravity[:, i] for i, a in enumerate("xyz")}
    if BALANCE in measured:
        cols["balance_tilt_true"] = sim.tilt
    cols["support"] = np.full(len(sim.q), robot.support)
    return cols
