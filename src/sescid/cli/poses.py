"""``sescid poses``: plan stable, collision-free, informative bench poses."""

from __future__ import annotations

import click

from sescid.base import OutputSet, TerminalProgress
from sescid.cli import common
from sescid.cli.flags import flags, record
from sescid.errors import OptionError
from sescid.io import pose_table, required_paper_convention
from sescid.kinds import COP, TORQUE, Kinds, kinds_label, parse_kinds
from sescid.planning import (
    DEFAULT_STANCE_COST,
    PAYLOAD_CANDIDATES,
    PlanOptions,
    Select,
    StancePlan,
    cop_half_extents,
    design_curve,
    free_sole,
    parse_stances,
    plan_payload_poses,
    plan_poses,
    sampling_limits,
    stance_robot,
)
from sescid.report import design_figure, mm
from sescid.robot import Robot
from sescid.tables import write_table


def _sole_notes(robot: Robot, capsules) -> list[str]:
    """Where the soles came from and what the floor check left out (any robot)."""
    from sescid.planning import ground_checks

    out = [s.note for s in (robot.sole, robot.free_sole) if s is not None and s.derived]
    if robot.sole is None:
        out.append("no sole: no profile sole size and no geometry on the support body")
    if capsules is not None:
        out += ground_checks(robot, capsules).notes
    return out


@click.command()
@common.robot_options
@common.number_option("--count", 38, 1, None, "Number of poses K to choose.")
@common.choice_option(
    "--select", Select, "d-optimal", "D-optimal (greedy + exchange) or K random candidates."
)
@common.seed_option
@common.file_option("--out", "Pose list CSV.", required=True)
@flags(PlanOptions, "n_candidates", "n_test")
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
@flags(PlanOptions, "clearance")
@click.option(
    "--range-deg", default=None, type=float, help="Also limit every joint to ±this [degrees]."
)
@click.option(
    "--urdf-limits", is_flag=True, help="Sample within the model's limits, not the paper's."
)
@flags(PlanOptions, "sigma")
@common.file_option("--figure", "Also write a PNG: expected CoP error vs K, D-optimal vs random.")
@click.option(
    "--paper-convention",
    is_flag=True,
    help="Add <joint>_paper_deg columns (the paper's Table 2 angle convention; op2).",
)
@flags(PlanOptions, "rigid", "allow_missing_meshes", "kinds", "tau_noise")
@click.option(
    "--tau-joints",
    default="all",
    show_default=True,
    help="Joints whose torque is measured: all, or a comma-separated list.",
)
@flags(PlanOptions, "mount")
@click.option(
    "--stances",
    default=None,
    help="Plan over these stances, comma-separated: a sole frame (standing on it), double "
    "(both feet, the CoP in the --support frame), gantry:<link> (held by it), stand:<frame>. "
    "One stance: as --support/--mount; several: one D-optimal design over the body parameters "
    "they share, visited stance by stance, with a 'support' column naming each pose's stance.",
)
@common.number_option(
    "--stance-cost", DEFAULT_STANCE_COST, 0, None,
    "Poses a stance change costs (several --stances): a plan with m stances chooses --count "
    "minus this times (m - 1) poses.",
)  # fmt: skip
@flags(PlanOptions, "hang_height")
@common.choice_option(
    "--check",
    ["none", "mujoco"],
    "none",
    "mujoco: keep only chosen poses that stand on the MuJoCo physics bench (replaced by "
    "the next best until all do; needs the mujoco extra).",
)
@click.option(
    "--payload",
    default=None,
    metavar="BODY",
    help="Plan the few poses that determine a payload on this link best (its mass and CoM; "
    "identify --payload); --count defaults to 8 then.",
)
@click.option(
    "--payload-mass",
    type=float,
    default=None,
    help="With --payload: its weighed mass [kg] (only its CoM is planned for).",
)
@common.force_option
def poses(**o):
    """Plan stable, collision-free poses for the bench experiment (paper §4), chosen to be
    informative, ordered to keep consecutive poses close.

    Columns: pose (id), support (each pose's stance: with --stances, or on both feet), one per
    joint in radians (servo convention), <joint>_deg, <joint>_ticks (when the robot profile
    knows its servo), cop_x_model, cop_y_model (the model's CoP in the stance's frame, m: a
    prediction, not a measurement; empty for a robot held in a gantry).
    """
    out, figure, count, select = o["out"], o["figure"], o["count"], o["select"]
    outs = OutputSet([out, figure], [common.model_input(o["robot_name"])], force=o["force"])
    torques = TORQUE in parse_kinds(o["kinds"])
    common.refuse_idle(("tau_noise", "tau_joints"), torques, "with --kinds cop")
    robot = common.load(o["robot_name"], o["support"])
    pc = required_paper_convention(robot) if o["paper_convention"] else None
    chosen = parse_stances(o["stances"], robot) if o["stances"] is not None else ()
    if len(chosen) == 1:  # one stance: as --support and --mount (printed in its frame)
        robot = stance_robot(robot, chosen[0])
    if o["payload"] is not None:
        _payload_plan(o, robot, pc, outs)
        return
    common.refuse_idle("payload_mass", o["payload_mass"] is None, "without --payload")
    if len(chosen) > 1 and figure is not None:
        raise OptionError("stances", "several stances are planned D-optimally, no figure")
    box = o["cop_box"], o["margin"], o["sole_size"]
    opt = record(
        PlanOptions, o, n_candidates=o["candidates"], mount=o["mount"],
        half_extents=None if box[:2] == (None, None) else cop_half_extents(robot, *box),
        limits=sampling_limits(robot, paper=not o["urdf_limits"], range_deg=o["range_deg"]),
        check=_stance_check if o["check"] == "mujoco" else None, check_name="MuJoCo bench",
        tau_joints=_joint_list(o["tau_joints"]),
    )  # fmt: skip
    plan = plan_poses(robot, count, select, o["seed"], opt, stances=chosen, cost=o["stance_cost"],
                      progress=TerminalProgress("candidates"))  # fmt: skip
    if isinstance(plan, StancePlan):
        _write_stance_plan(robot, plan, out, outs, pc)
        return
    label = chosen[0].label if chosen else "double" if plan.mount == "double" else None
    table = pose_table(robot, plan.q, support=label, paper=pc,
                       cop=None if plan.mount == "gantry" else plan.cop)  # fmt: skip
    _echo_plan(robot, plan, opt, table.notes)
    curve = None
    if figure is not None:
        curve = design_curve(plan, seed=o["seed"], progress=TerminalProgress("figure: K values"))
    with outs:
        write_table(outs.path(out), table.columns)
        if curve is not None:
            rows = kinds_label(plan.kinds)
            what = "" if plan.quantity == "CoP" else f" ({rows} rows, CoM x/y error)"
            design_figure(curve, outs.path(figure), title=f"{robot.name}: pose selection{what}")
    click.echo(f"wrote {out}: {count} poses ({len(table.columns)} columns)")
    if curve is not None:
        click.echo(f"wrote {figure}")


def _echo_plan(robot: Robot, plan, opt: PlanOptions, table_notes: list[str]) -> None:
    """What the plan found: the candidates, the checks, notes, the expected error, the path."""
    echo = click.echo
    half = None if plan.mount == "gantry" else plan.candidates.half_extents
    capsules = plan.candidates.capsules
    notes = list(capsules.notes) if capsules is not None else []
    if plan.mount != "gantry":
        notes += _sole_notes(robot, capsules)
    notes += plan.notes + table_notes
    echo(f"candidates: {plan.candidates.summary()}")
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
            + (f"free foot {free} ≥ {opt.clearance * 1e3:g} mm above the floor; " if free else "")
            + f"{n_pairs} capsule pairs checked"
        )
    else:
        echo(f"  held by {robot.support} (gantry); {n_pairs} capsule pairs checked")
    for note in notes:
        echo(f"  note: {note}")
    count = len(plan.q)
    echo(f"identifiable subspace: p = {plan.rank}; chose {count} poses ({plan.method}, "
         f"{kinds_label(plan.kinds)} rows)")  # fmt: skip
    echo(f"expected noise-free {_error_line(plan, opt.sigma, opt.tau_noise)}: chosen "
         f"{mm(plan.expected_error)}, {count} random {mm(plan.random_error)} (median)")  # fmt: skip
    if plan.poses_for_all is not None:
        echo(f"warning: these {count} poses determine {plan.determined} of the {plan.rank} "
             "combinations (a pose's rows repeat one another here); about "
             f"{plan.poses_for_all} poses determine them all (--count), or measure more "
             "joints")  # fmt: skip
    echo(
        f"joint-space path from the zero pose: {plan.path_unordered:.2f} rad in selection "
        f"order → {plan.path_ordered:.2f} rad ordered"
    )


def _payload_plan(o, robot: Robot, pc, outs: OutputSet) -> None:
    """Poses --payload: the poses that determine a payload best, and their table."""
    if o["stances"] is not None or o["mount"] is not None or o["select"] != "d-optimal":
        raise OptionError("payload", "--payload plans D-optimal poses on the --support foot")
    count = o["count"] if common.given("count") else 8
    n_candidates = o["candidates"] or PAYLOAD_CANDIDATES
    if n_candidates < count:
        raise OptionError("count", f"must not exceed --candidates ({n_candidates})")
    half = cop_half_extents(robot, o["cop_box"], o["margin"], o["sole_size"])
    opt = record(
        PlanOptions, o, n_candidates=n_candidates, mount=None, half_extents=half,
        limits=sampling_limits(robot, paper=not o["urdf_limits"], range_deg=o["range_deg"]),
        check=None, check_name="", tau_joints=_joint_list(o["tau_joints"]),
    )  # fmt: skip
    plan = plan_payload_poses(robot, o["payload"], count, o["seed"], opt, o["payload_mass"],
                              progress=TerminalProgress("candidates"))  # fmt: skip
    table = pose_table(robot, plan.q, paper=pc, cop=plan.cop)
    noise = _error_line_payload(plan.kinds, opt.sigma, opt.tau_noise)
    n_par = 3 if o["payload_mass"] else 4
    click.echo(f"payload on {plan.body}: chose {count} of {plan.n_candidates} candidates "
               f"(D-optimal over its {n_par} parameters, {noise})")  # fmt: skip
    for label, std in (("chosen", plan.std), (f"{count} random (median)", plan.random_std)):
        mass = "" if o["payload_mass"] else f"mass ± {std[0] * 1e3:.0f} g, "
        if label == "chosen":
            click.echo(f"  (for {plan.nominal_mass:.3g} kg at {plan.body}'s origin; "
                       "--payload-mass gives yours)")  # fmt: skip
        com = ", ".join(f"{v * 1e3:.1f}" for v in std[1:])
        click.echo(f"  expected std, {label}: {mass}CoM ± ({com}) mm")
    with outs:
        write_table(outs.path(o["out"]), table.columns)
    click.echo(f"wrote {o['out']}: {count} poses ({len(table.columns)} columns)")


def _error_line_payload(kinds: Kinds, sigma: float, tau_noise: float) -> str:
    parts = [f"σ = {sigma * 1e3:g} mm"] if COP in kinds else []
    return ", ".join(parts + ([f"σ_τ = {tau_noise:g} N·m"] if TORQUE in kinds else []))


def _stance_check(stance, robot: Robot):
    """The MuJoCo standing check of a stance on its foot or feet (None held in a gantry)."""
    from sescid.bench import standing_check

    return None if stance.mount == "gantry" else standing_check(robot, stance.mount == "double")


def _write_stance_plan(robot: Robot, sp, out: str, outs: OutputSet, pc) -> None:
    """Print a plan over several stances and write its pose table (with ``support``)."""
    echo = click.echo
    for rep in sp.reports:
        echo(f"{rep.stance.label}: {rep.stance.describe()}: {rep.candidates.summary()}")
        for note in rep.candidates.notes:
            echo(f"  note: {note}")
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
    table = pose_table(robot, sp.q, support=sp.stance, paper=pc, cop=sp.cop)
    for note in table.notes:
        echo(f"note: {note}")
    with outs:
        write_table(outs.path(out), table.columns)
    echo(f"wrote {out}: {len(sp.q)} poses ({len(table.columns)} columns)")


def _joint_list(spec: str) -> tuple[str, ...] | None:
    """``--tau-joints``: None for all, else the comma-separated names."""
    spec = spec.strip()
    if spec in ("", "all"):
        return None
    return tuple(j.strip() for j in spec.split(",") if j.strip())


def _error_line(plan, noise: float, tau_noise: float) -> str:
    """What the expected error is of, and the noise it assumes."""
    if plan.quantity == "CoP":
        return f"CoP error on fresh poses (σ = {noise * 1e3:g} mm)"
    sig = f"σ_τ = {tau_noise:g} N·m" + (f", σ = {noise * 1e3:g} mm" if COP in plan.kinds else "")
    return f"CoM x/y error on fresh poses ({sig})"
