"""Pose planning for a bench identification: stable, collision-free, informative poses.

Pipeline (vectorised across poses, SI units, radians): sampling limits (``limits``) →
candidates that are statically stable, ground-clear and free of self-collision (``candidates``,
``stability``, ``collision``) → D-optimal choice and its expected CoP error (``doptimal``) →
visiting order (``ordering``); ``plan_poses`` runs it all.
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
)
from sescid.planning.ordering import order_poses, path_length
from sescid.planning.plan import PosePlan, design_curve, plan_poses
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
    "GroundChecks",
    "PaperConvention",
    "PosePlan",
    "Selection",
    "box_capsules",
    "candidates",
    "collision_capsules",
    "collision_free_mask",
    "collision_free_mask_numpy",
    "cop_half_extents",
    "design_curve",
    "expected_cop_error",
    "first_contact",
    "ground_checks",
    "free_sole",
    "ground_clear_mask",
    "identifiable_basis",
    "information",
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
]
