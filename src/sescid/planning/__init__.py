"""Pose planning for a bench identification: stable, collision-free, informative poses.

Pipeline (vectorised across poses, SI units, radians): sampling limits (``limits``: unlimited
joints get a stated range) → candidates (``candidates``: uniform draws, or draws moved over the
foot by the CoM Jacobian, ``adjust``, ``com``) that are stable on a compliant robot
(``stability``: the CoP box; ``compliance``: servo sag, sole tilt, backlash), clear of the floor
on every body's geometry (``ground``) and free of self-collision (``collision``) → D-optimal
choice and its expected CoP error (``doptimal``), optionally checked on a physics bench
(``PlanOptions.check``) → visiting order (``ordering``); ``plan_poses`` runs it all. Designs
for joint torques, alone or with the CoP (``PlanOptions.kinds``): each pose's rows of those
kinds with a torque offset per joint as nuisance (``kinds``), chosen D-optimally in blocks
(``blocks``), the expected CoM x/y error (``plan_kinds``); a robot held in a fixture
(``gantry``): no balance, only joint limits, the floor and self-collision; a payload on a
calibrated robot (``payload``): the few poses that determine its mass and CoM. Every kernel runs
without fast-math and breaks near-ties by index: the same poses on every CPU.
"""

from sescid.planning.design.blocks import BlockDesign, schur_logdet, select_blocks
from sescid.planning.design.doptimal import (
    Selection,
    expected_cop_error,
    identifiable_basis,
    information,
    per_row_information,
    projected_regressor,
    random_cop_error,
    select_d_optimal,
)
from sescid.planning.design.kinds import (
    DEFAULT_TAU_NOISE,
    DESIGN_KINDS,
    BlockRows,
    DesignKind,
    DesignKinds,
    TorqueRows,
    block_rows,
    design_kinds,
    expected_com_error,
    kind_basis,
    min_block_poses,
    pool_information,
    random_com_error,
    schur_information,
)
from sescid.planning.design.payload import (
    PAYLOAD_CANDIDATES,
    PayloadPlan,
    payload_rows,
    plan_payload_poses,
)
from sescid.planning.design.stances import stance_robot
from sescid.planning.feasibility.candidates import (
    CandidateOptions,
    Candidates,
    Sampling,
    candidates,
)
from sescid.planning.feasibility.collision import (
    Capsules,
    box_capsules,
    collision_capsules,
    collision_free_mask,
    collision_free_mask_numpy,
    first_contact,
    segment_distance,
)
from sescid.planning.feasibility.com import ComState, com_state, level_cop
from sescid.planning.feasibility.compliance import (
    Compliance,
    compliance,
    compliant_margin,
    dynamic_cop,
)
from sescid.planning.feasibility.double import double_candidates
from sescid.planning.feasibility.gantry import (
    GANTRY_LIFT,
    GantryOptions,
    gantry_candidates,
    gantry_floor,
    held_trunk,
    resolve_mount,
    standing_height,
)
from sescid.planning.feasibility.ground import GroundChecks, ground_checks
from sescid.planning.feasibility.limits import (
    PaperConvention,
    load_paper_convention,
    paper_convention,
    sampling_limits,
    unlimited_joints,
)
from sescid.planning.feasibility.stability import (
    DEFAULT_CLEARANCE,
    FALLBACK_COP_BOX,
    cop_half_extents,
    free_sole,
    ground_clear_mask,
    sole_corners,
    stable_mask,
)
from sescid.planning.ordering import order_poses, path_length
from sescid.planning.plan import design_curve, plan_poses
from sescid.planning.plan_kinds import block_curve, choose_blocks
from sescid.planning.plan_stances import (
    DEFAULT_STANCE_COST,
    StancePlan,
    StanceReport,
    plan_stances,
)
from sescid.planning.plan_types import (
    PlanOptions,
    PoseCheck,
    PosePlan,
    Quantity,
    Select,
    default_candidates,
)
from sescid.stance import MOUNTS, Mount, Stance, parse_stances

__all__ = [
    "PAYLOAD_CANDIDATES",
    "PayloadPlan",
    "payload_rows",
    "plan_payload_poses",
    "DEFAULT_CLEARANCE",
    "DEFAULT_TAU_NOISE",
    "DESIGN_KINDS",
    "FALLBACK_COP_BOX",
    "GANTRY_LIFT",
    "MOUNTS",
    "BlockDesign",
    "BlockRows",
    "CandidateOptions",
    "Candidates",
    "Capsules",
    "ComState",
    "Compliance",
    "DesignKind",
    "DesignKinds",
    "GantryOptions",
    "GroundChecks",
    "Mount",
    "TorqueRows",
    "PaperConvention",
    "PlanOptions",
    "PoseCheck",
    "PosePlan",
    "Quantity",
    "Sampling",
    "Select",
    "Selection",
    "block_curve",
    "block_rows",
    "box_capsules",
    "candidates",
    "choose_blocks",
    "collision_capsules",
    "collision_free_mask",
    "collision_free_mask_numpy",
    "com_state",
    "compliance",
    "compliant_margin",
    "cop_half_extents",
    "default_candidates",
    "design_curve",
    "design_kinds",
    "dynamic_cop",
    "expected_com_error",
    "expected_cop_error",
    "first_contact",
    "gantry_candidates",
    "gantry_floor",
    "ground_checks",
    "free_sole",
    "ground_clear_mask",
    "held_trunk",
    "identifiable_basis",
    "information",
    "kind_basis",
    "level_cop",
    "load_paper_convention",
    "min_block_poses",
    "order_poses",
    "paper_convention",
    "path_length",
    "per_row_information",
    "plan_poses",
    "pool_information",
    "projected_regressor",
    "random_com_error",
    "random_cop_error",
    "resolve_mount",
    "sampling_limits",
    "schur_information",
    "schur_logdet",
    "segment_distance",
    "select_blocks",
    "select_d_optimal",
    "sole_corners",
    "stable_mask",
    "standing_height",
    "unlimited_joints",
    "DEFAULT_STANCE_COST",
    "Stance",
    "StancePlan",
    "StanceReport",
    "double_candidates",
    "parse_stances",
    "plan_stances",
    "stance_robot",
]
