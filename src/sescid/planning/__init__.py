"""Pose planning for a bench identification: stable, collision-free, informative poses.

Pipeline (vectorised across poses, SI units, radians): sampling limits (``limits``: unlimited
joints get a stated range) → candidates (``candidates``: uniform draws, or draws moved over the
foot by the CoM Jacobian, ``adjust``, ``com``) that are stable on a compliant robot
(``stability``: the CoP box; ``compliance``: servo sag, sole tilt, backlash), clear of the floor
on every body's geometry (``ground``) and free of self-collision (``collision``) → D-optimal
choice and its expected CoP error (``doptimal``), optionally checked on a physics bench
(``PlanOptions.check``) → visiting order (``ordering``); ``plan_poses`` runs it all. Every
kernel runs without fast-math and breaks near-ties by index: the same poses on every CPU.
"""

from __future__ import annotations

from sescid.planning.candidates import Candidates, candidates
from sescid.planning.collision import (
    Capsules,
    box_capsules,
    collision_capsules,
    collision_free_mask,
    collision_free_mask_numpy,
    first_contact,
    segment_distance,
)
from sescid.planning.com import ComState, com_state, level_cop
from sescid.planning.compliance import Compliance, compliance, compliant_margin, dynamic_cop
from sescid.planning.doptimal import (
    Selection,
    expected_cop_error,
    identifiable_basis,
    information,
    per_row_information,
    projected_regressor,
    random_cop_error,
    select_d_optimal,
)
from sescid.planning.ground import GroundChecks, ground_checks
from sescid.planning.limits import (
    PaperConvention,
    load_paper_convention,
    paper_convention,
    sampling_limits,
    unlimited_joints,
)
from sescid.planning.ordering import order_poses, path_length
from sescid.planning.plan import (
    PlanOptions,
    PoseCheck,
    PosePlan,
    default_candidates,
    design_curve,
    plan_poses,
)
from sescid.planning.stability import (
    DEFAULT_CLEARANCE,
    FALLBACK_COP_BOX,
    cop_half_extents,
    free_sole,
    ground_clear_mask,
    sole_corners,
    stable_mask,
)

__all__ = [
    "DEFAULT_CLEARANCE",
    "FALLBACK_COP_BOX",
    "Candidates",
    "Capsules",
    "ComState",
    "Compliance",
    "GroundChecks",
    "PaperConvention",
    "PlanOptions",
    "PoseCheck",
    "PosePlan",
    "Selection",
    "box_capsules",
    "candidates",
    "collision_capsules",
    "collision_free_mask",
    "collision_free_mask_numpy",
    "com_state",
    "compliance",
    "compliant_margin",
    "cop_half_extents",
    "default_candidates",
    "design_curve",
    "dynamic_cop",
    "expected_cop_error",
    "first_contact",
    "ground_checks",
    "free_sole",
    "ground_clear_mask",
    "identifiable_basis",
    "information",
    "level_cop",
    "load_paper_convention",
    "order_poses",
    "paper_convention",
    "path_length",
    "per_row_information",
    "plan_poses",
    "projected_regressor",
    "random_cop_error",
    "sampling_limits",
    "segment_distance",
    "select_d_optimal",
    "sole_corners",
    "stable_mask",
    "unlimited_joints",
]
