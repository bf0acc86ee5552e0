"""``sescid poses``: plan stable, collision-free, informative bench poses."""

from __future__ import annotations

import dataclasses
from typing import Literal

import click
import numpy as np

from sescid.base import MODEL_COP_COLUMNS, OutputSet, TerminalProgress
from sescid.cli.common import (
    force_option,
    load,
    model_input,
    refuse_idle,
    robot_options,
    seed_option,
)
from sescid.errors import OptionError, SescidError, choices
from sescid.estimation import min_poses
from sescid.io import write_table
from sescid.planning import (
    DEFAULT_CLEARANCE,
    DEFAULT_STANCE_COST,
    DEFAULT_TAU_NOISE,
    DesignKind,
    Mount,
    PlanOptions,
    Select,
    block_curve,
    cop_half_extents,
    default_candidates,
    design_curve,
    free_sole,
    min_block_poses,
    parse_stances,
    plan_poses,
    plan_stances,
    resolve_mount,
    sampling_limits,
    stance_robot,
)
from sescid.planning import paper_convention as robot_paper_convention
from sescid.report import design_figure, mm
from sescid.simulation import PAPER_NOISE


def _sole_notes(robot, capsules) -> list[str]:
    """Where the soles came from and what the floor check left out (any robot)."""
    from sescid.planning import ground_checks

    out = [s.note for s in (robot.sole, robot.free_sole) if s is not None and s.derived]
    if robot.sole is None:
        out.append("no sole: no profile sole size and no geometry on the support body")
    if capsules is not None:
        out += ground_checks(robot, capsules).notes
    return out


@click.command()
@robot_options
@click.option(
    "--count",
    default=38,
    show_default=True,
    type=click.IntRange(min=1),
    help="Number of poses K to choose.",
)
@click.option(
    "--select",
    type=click.Choice(choices(Select)),
    default="d-optimal",
    show_default=True,
    help="D-optimal (greedy + exchange) or K random candidates.",
)
@seed_option
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Pose list CSV.")
@click.option(
    "--candidates",
    "n_candidates",
    default=None,
    type=click.IntRange(min=1, max=10_000_000),
    help="Stable, collision-free candidate poses to choose from "
    "[default, d-optimal: 20000 for uniform draws (op2), 5000 with the adjusted sampler; "
    "random: --count (a random subset of random candidates is random)].",
)
@click.option(
    "--test-poses",
    default=2_000,
    show_default=True,
    type=click.IntRange(min=1, max=10_000_000),
    help="Held-out poses for the error.",
)
@click.option(
    "--cop-box",
    default=None,
    type=float,
    help="Stability: model CoP within ±this of the sole centre in x and y [m] "
    "(default: the robot profile's; op2 the paper's 0.023).",
)
@click.option(
    "--margin",
    default=None,
    type=float,
    help="Stability: CoP inside the sole rectangle shrunk by this [m] (instead of --cop-box).",
)
@click.option(
    "--sole-size",
    nargs=2,
    type=float,
    default=None,
    help="Sole rectangle length and width [m] for --margin (default: the profile's).",
)
@click.option(
    "--foot-clearance",
    "clearance",
    default=DEFAULT_CLEARANCE,
    show_default=True,
    help="The free foot (all its geometry) above the floor by at least this [m]; on a gantry, "
    "every body.",
)
@click.option(
    "--range-deg", default=None, type=float, help="Also limit every joint to ±this [degrees]."
)
@click.option(
    "--urdf-limits", is_flag=True, help="Sample within the model's limits, not the paper's."
)
@click.option(
    "--noise",
    default=PAPER_NOISE,
    show_default=True,
    help="CoP noise σ for the expected error [m].",
)
@click.option(
    "--figure",
    default=None,
    type=click.Path(dir_okay=False),
    help="Also write a PNG: expected CoP error vs K, D-optimal vs random.",
)
@click.option(
    "--paper-convention",
    is_flag=True,
    help="Add <joint>_paper_deg columns (the paper's Table 2 angle convention; op2).",
)
@click.option(
    "--rigid",
    is_flag=True,
    help="Stability: the CoP box only, no compliant-robot margin (servo sag, sole tilt, "
    "backlash from the robot profile).",
)
@click.option(
    "--kinds",
    type=click.Choice(choices(DesignKind)),
    default="cop",
    show_default=True,
    help="What the robot measures at each pose, for the D-optimal choice: cop (a foot sensor), "
    "tau (joint torques, an unknown offset per joint) or both.",
)
@click.option(
    "--tau-noise",
    default=DEFAULT_TAU_NOISE,
    show_default=True,
    type=float,
    help="Joint-torque noise σ per pose for the design and its expected error [N·m].",
)
@click.option(
    "--tau-joints",
    default="all",
    show_default=True,
    help="Joints whose torque is measured: all, or a comma-separated list.",
)
@click.option(
    "--mount",
    type=click.Choice(choices(Mount)),
    default=None,
    help="stand: on the support foot (balance checked); gantry: the support link (a torso, "
    "pelvis) held level, the robot hanging free (joint limits, floor, self-collision only; "
    "--kinds tau); double: on both feet, the other foot's sole flat on the floor (CoP of the "
    "whole robot in the support foot's frame; --kinds cop). Default: gantry when the robot's "
    "mass splits at the support (a trunk), else stand.",
)
@click.option(
    "--stances",
    default=None,
    help="Plan over these stances, comma-separated: a sole frame (standing on it), double "
    "(both feet, the CoP in the --support frame), gantry:<link> (held by it), stand:<frame>. "
    "One stance: as --support/--mount; several: one D-optimal design over the body parameters "
    "they share, visited stance by stance, with a 'support' column naming each pose's stance.",
)
@click.option(
    "--stance-cost",
    default=DEFAULT_STANCE_COST,
    show_default=True,
    type=click.FloatRange(min=0),
    help="Poses a stance change costs (several --stances): a plan with m stances chooses "
    "--count minus this times (m - 1) poses.",
)
@click.option(
    "--hang-height",
    default=None,
    type=float,
    help="Gantry: height of the held link's frame above the floor [m] (default: its height "
    "when the robot stands at the zero pose + 50 mm).",
)
@click.option(
    "--check",
    "check",
    type=click.Choice(["none", "mujoco"]),
    default="none",
    show_default=True,
    help="mujoco: keep only chosen poses that stand on the MuJoCo physics bench (replaced by "
    "the next best until all do; needs the mujoco extra).",
)
@force_option
def poses(
    robot_name,
    support,
    count,
    select: Select,
    seed,
    out,
    n_candidates,
    test_poses,
    cop_box,
    margin,
    sole_size,
    clearance,
    range_deg,
    urdf_limits,
    noise,
    figure,
    paper_convention: bool,
    rigid: bool,
    kinds: DesignKind,
    tau_noise: float,
    tau_joints: str,
    mount: Mount | None,
    stances: str | None,
    stance_cost: float,
    hang_height: float | None,
    check: Literal["none", "mujoco"],
    force: bool,
):
    """Plan stable, collision-free poses for the bench experiment (paper §4), chosen to be
    informative, ordered to keep consecutive poses close.

    Columns: pose (id), support (each pose's stance: with --stances, or on both feet), one per
    joint in radians (servo convention), <joint>_deg, <joint>_ticks (when the robot profile
    knows its servo), cop_x_model, cop_y_model (the model's CoP in the stance's frame, m: a
    prediction, not a measurement; empty for a robot held in a gantry).
    """
    outs = OutputSet([out, figure], [model_input(robot_name)], force=force)
    refuse_idle(("tau_noise", "tau_joints"), kinds != "cop", "with --kinds cop")
    robot = load(robot_name, support)
    chosen = parse_stances(stances, robot) if stances is not None else ()
    if chosen and mount is not None:
        raise OptionError("mount", "--stances names each stance's mount (gantry:<link>, double)")
    if len(chosen) == 1:  # one stance: as --support and --mount
        robot, mount = stance_robot(robot, chosen[0]), chosen[0].mount
    if n_candidates is None and len(chosen) > 1:
        n_candidates = default_candidates(robot, select, count, kinds) // len(chosen)
    if n_candidates is None:
        n_candidates = default_candidates(robot, select, count, kinds)
    held = len(chosen) < 2 and resolve_mount(robot, mount, kinds) == "gantry"  # said first
    need = min_poses(robot)
    if count < need and kinds == "cop":
        raise OptionError("count", f"{count}: at least {need} poses are needed on {robot.name}")
    if n_candidates < count:
        raise OptionError("count", f"must not exceed --candidates ({n_candidates})")
    if not noise > 0 or not clearance >= 0:
        raise OptionError("noise", "must be > 0 and --foot-clearance ≥ 0 (metres)")
    if not tau_noise > 0:
        raise OptionError("tau_noise", f"must be > 0 (N·m), got {tau_noise}")
    pc = robot_paper_convention(robot)
    if paper_convention and pc is None:
        raise OptionError("paper_convention", "--paper-convention: this robot's profile has none")
    half = None if held else cop_half_extents(robot, cop_box, margin, sole_size)
    limits = sampling_limits(robot, paper=not urdf_limits, range_deg=range_deg)
    pose_check = None
    if check == "mujoco" and len(chosen) < 2:
        from sescid.bench import standing_check

        pose_check = standing_check(robot, mount == "double")
    opt = PlanOptions(
        n_candidates=n_candidates,
        n_test=test_poses,
        sigma=noise,
        limits=limits,
        half_extents=half,
        clearance=clearance,
        rigid=rigid,
        check=pose_check,
        check_name="MuJoCo bench",
        kinds=kinds,
        tau_noise=tau_noise,
        tau_joints=_joint_list(tau_joints),
        mount=mount,
        hang_height=hang_height,
    )
    if len(chosen) > 1:
        if select != "d-optimal" or figure is not None:
            raise OptionError("stances", "several stances are planned D-optimally, no figure")
        opt = dataclasses.replace(opt, half_extents=None if cop_box is None and margin is None
                                  else half, mount=None)  # fmt: skip
        checks = (lambda st, rb: _stance_check(st, rb)) if check == "mujoco" else None
        sp = plan_stances(robot, chosen, count, seed, opt, stance_cost, check=checks,
                          progress=TerminalProgress("candidates"))  # fmt: skip
        _write_stance_plan(robot, sp, out, outs, pc if paper_convention else None)
        return
    plan = plan_poses(robot, count, select, seed, opt, progress=TerminalProgress("candidates"))
    capsules = plan.candidates.capsules
    notes = list(capsules.notes) if capsules is not None else []
    if plan.mount != "gantry":
        notes += _sole_notes(robot, capsules)
    notes += plan.notes
    label = chosen[0].label if chosen else "double" if plan.mount == "double" else None
    first = {} if label is None else {"support": np.full(count, label)}
    cols = _pose_columns(robot, plan.q, first, pc if paper_convention else None, notes)
    if plan.mount != "gantry":
        cols |= {MODEL_COP_COLUMNS[k]: plan.cop[:, k] for k in range(2)}
    echo = click.echo
    cand = plan.candidates
    echo(f"candidates: {cand.summary()}")
    free = free_sole(robot)
    n_pairs = len(capsules.pairs) if capsules is not None else 0
    if half is not None and plan.mount == "double":
        echo(
            f"  stability: CoP inside both feet's ±{half[0] * 1e3:.1f} mm (x) "
            f"±{half[1] * 1e3:.1f} mm (y) boxes; {n_pairs} capsule pairs checked"
        )
    elif half is not None:
        echo(
            f"  stability: CoP within ±{half[0] * 1e3:.1f} mm (x) ±{half[1] * 1e3:.1f} mm (y); "
            + (f"free foot {free} ≥ {clearance * 1e3:g} mm above the floor; " if free else "")
            + f"{n_pairs} capsule pairs checked"
        )
    else:
        echo(f"  held by {robot.support} (gantry); {n_pairs} capsule pairs checked")
    for note in notes:
        echo(f"  note: {note}")
    echo(f"identifiable subspace: p = {plan.rank}; chose {count} poses ({select}, {kinds} rows)")
    echo(f"expected noise-free {_error_line(plan, noise, tau_noise)}: chosen "
         f"{mm(plan.expected_error)}, {count} random {mm(plan.random_error)} (median)")  # fmt: skip
    echo(
        f"joint-space path from the zero pose: {plan.path_unordered:.2f} rad in selection "
        f"order → {plan.path_ordered:.2f} rad ordered"
    )
    curve = _curve(plan, need, count, n_candidates, noise, seed) if figure else None
    with outs:
        write_table(outs.path(out), cols)
        if curve is not None:
            what = "" if plan.rows is None else f" ({kinds} rows, CoM x/y error)"
            design_figure(curve, outs.path(figure), title=f"{robot.name}: pose selection{what}")
    echo(f"wrote {out}: {count} poses ({len(cols)} columns)")
    if curve is not None:
        echo(f"wrote {figure}")


def _pose_columns(robot, q, first: dict, pc, notes: list[str]) -> dict[str, np.ndarray]:
    """The pose table: ``pose``, the ``first`` columns, one per joint (rad), ``<joint>_deg``,
    ``<joint>_ticks`` (a profile servo), ``<joint>_paper_deg`` (``pc``: the paper's convention)."""
    cols: dict[str, np.ndarray] = {"pose": np.arange(len(q))} | first
    names = robot.joint_names
    cols |= {j: q[:, k] for k, j in enumerate(names)}
    cols |= {f"{j}_deg": np.degrees(q[:, k]) for k, j in enumerate(names)}
    servo = robot.profile.servo
    if servo is not None:
        try:
            ticks = servo.to_ticks(q)
            cols |= {f"{j}_ticks": ticks[:, k] for k, j in enumerate(names)}
        except SescidError:
            notes.append(f"no _ticks columns: some angles are outside the {servo.name} range")
    if pc is not None:
        qp = np.degrees(pc.to_paper(q))
        cols |= {f"{j}_paper_deg": qp[:, k] for k, j in enumerate(names)}
    return cols


def _stance_check(stance, robot):
    """The MuJoCo standing check of a stance on its foot or feet (None held in a gantry)."""
    from sescid.bench import standing_check

    return None if stance.mount == "gantry" else standing_check(robot, stance.mount == "double")


def _write_stance_plan(robot, sp, out: str, outs: OutputSet, pc) -> None:
    """Print a plan over several stances and write its pose table (with ``support``)."""
    echo = click.echo
    for rep in sp.reports:
        echo(f"{rep.stance.label}: {rep.stance.describe()}: {rep.candidates.summary()}")
        for note in rep.candidates.notes:
            echo(f"  note: {note}")
    notes: list[str] = []
    for note in sp.notes:
        echo(f"note: {note}")
    echo(f"rank over the {sp.n_theta} body parameters (data alone): pooled {sp.rank}")
    for rep in sp.reports:
        echo(f"  {rep.stance.label}: alone {rep.rank}, adds {rep.adds} to the others; "
             f"{rep.poses} poses chosen")  # fmt: skip
    ref = sp.reference.label
    echo(f"expected CoM error on fresh poses (MAP, CAD prior): pooled {mm(sp.expected_com)} 3-D, "
         f"{mm(sp.expected_com_xy)} x/y; {ref} alone with {len(sp.q) + int(sp.cost * sp.changes)}"
         f" poses {mm(sp.reference_com)} 3-D, {mm(sp.reference_com_xy)} x/y")  # fmt: skip
    if sp.n_checked:
        echo(f"MuJoCo bench check: {sp.n_checked} poses simulated, {sp.n_check_failed} did not "
             "stand and were replaced")  # fmt: skip
    echo(f"{sp.changes} stance change(s); joint-space path {sp.path_length:.2f} rad")
    cols = _pose_columns(robot, sp.q, {"support": sp.stance}, pc, notes)
    cols |= {MODEL_COP_COLUMNS[k]: sp.cop[:, k] for k in range(2)}
    for note in notes:
        echo(f"note: {note}")
    with outs:
        write_table(outs.path(out), cols)
    echo(f"wrote {out}: {len(sp.q)} poses ({len(cols)} columns)")


def _joint_list(spec: str) -> tuple[str, ...] | None:
    """``--tau-joints``: None for all, else the comma-separated names."""
    spec = spec.strip()
    if spec in ("", "all"):
        return None
    return tuple(j.strip() for j in spec.split(",") if j.strip())


def _error_line(plan, noise: float, tau_noise: float) -> str:
    """What the expected error is of, and the noise it assumes."""
    if plan.rows is None:
        return f"CoP error on fresh poses (σ = {noise * 1e3:g} mm)"
    sig = f"σ_τ = {tau_noise:g} N·m" + (f", σ = {noise * 1e3:g} mm" if plan.kinds == "both" else "")
    return f"CoM x/y error on fresh poses ({sig})"


def _curve(plan, need: int, count: int, n_candidates: int, noise: float, seed: int):
    """The figure's expected error vs K (the CoP's, or the CoM's for torque rows)."""
    progress = TerminalProgress("figure: K values")
    if plan.rows is not None:
        r = plan.rows
        need = min_block_poses(r.x.shape[1], r.p, r.n_nuisance)
    ks = [need, 25, 30, 38, 50, 70, 100, 150, 200, count]
    ks = sorted({k for k in ks if need <= k <= min(n_candidates, max(200, count))})
    if plan.rows is not None:
        return block_curve(plan.rows, plan.c_test, ks, seed, progress=progress)
    return design_curve(plan.a_pool, plan.c_test, ks, noise, seed, progress=progress)
