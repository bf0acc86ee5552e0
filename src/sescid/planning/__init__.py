"""Pose planning for a bench identification: stable, collision-free, informative poses.

Pipeline (vectorised across poses, SI units, radians): sampling limits (``limits``: unlimited
joints get a stated range) → candidates (``candidates``: uniform draws, or draws moved over the
foot by the CoM Jacobian, ``adjust``, ``com``) that are stable on a compliant robot
(``stability``: the CoP box; ``compliance``: servo sag, sole tilt, backlash), clear of the floor
on every body's geometry (``ground``) and free of self-collision (``collision``) → D-optimal
choice (``design.engine``: the CoP's rows by ``doptimal``, rows of joint torques, alone or
with the CoP, with a torque offset per joint as nuisance by ``blocks``, ``kinds``) and its
expected error, optionally checked on a physics bench (``PlanOptions.check``) → visiting order
(``ordering``). ``plan_poses`` runs it all, in one stance or over several (``pooled``: one design
over the body parameters they share), the candidates of each from one funnel (``funnel``:
standing, on both feet, or held in a fixture, ``gantry``: no balance, only joint limits, the
floor and self-collision). A payload on a calibrated robot (``payload``): the few poses that
determine its mass and CoM. Every kernel runs without fast-math and breaks near-ties by index:
the same poses on every CPU. Exported: what the layers above call; the rest from its module.
"""

from sescid.kinds import DesignKind
from sescid.planning.design.doptimal import identifiable_basis, projected_regressor
from sescid.planning.design.kinds import (
    TorqueRows,
    block_rows,
    design_kinds,
    kind_basis,
    min_block_poses,
)
from sescid.planning.design.payload import PAYLOAD_CANDIDATES, PayloadPlan, plan_payload_poses
from sescid.planning.design.stances import stance_robot
from sescid.planning.feasibility.candidates import CandidateOptions, Candidates, candidates
from sescid.planning.feasibility.collision import collision_capsules, collision_free_mask
from sescid.planning.feasibility.compliance import compliance
from sescid.planning.feasibility.double import double_candidates
from sescid.planning.feasibility.gantry import GantryOptions, gantry_candidates, resolve_mount
from sescid.planning.feasibility.ground import ground_checks
from sescid.planning.feasibility.limits import PaperConvention, paper_convention, sampling_limits
from sescid.planning.feasibility.stability import cop_half_extents, free_sole
from sescid.planning.plan import design_curve, plan_poses
from sescid.planning.plan_types import (
    Plan,
    PlanOptions,
    PoseCheck,
    PosePlan,
    Quantity,
    Select,
    StanceCheck,
    StancePlan,
)
from sescid.planning.pooled import DEFAULT_STANCE_COST
from sescid.stance import Mount, Stance, held_trunk, parse_stances

__all__ = [
    "DEFAULT_STANCE_COST",
    "PAYLOAD_CANDIDATES",
    "CandidateOptions",
    "Candidates",
    "DesignKind",
    "GantryOptions",
    "Mount",
    "PaperConvention",
    "PayloadPlan",
    "Plan",
    "PlanOptions",
    "PoseCheck",
    "PosePlan",
    "Quantity",
    "Select",
    "Stance",
    "StanceCheck",
    "StancePlan",
    "TorqueRows",
    "block_rows",
    "candidates",
    "collision_capsules",
    "collision_free_mask",
    "compliance",
    "cop_half_extents",
    "design_curve",
    "design_kinds",
    "double_candidates",
    "free_sole",
    "gantry_candidates",
    "ground_checks",
    "held_trunk",
    "identifiable_basis",
    "kind_basis",
    "min_block_poses",
    "paper_convention",
    "parse_stances",
    "plan_payload_poses",
    "plan_poses",
    "projected_regressor",
    "resolve_mount",
    "sampling_limits",
    "stance_robot",
]
