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
(``gantry``): no balance, only joint limits, the floor and self-collision. On both feet
(``double``): the other foot's sole closed onto the floor by inverse kinematics (``closure``),
the CoP inside both feet's support. Over a set of stances (``stances``, ``plan_stances``): one
design over the body parameters they share, a cost per stance change. Every kernel runs
without fast-math and breaks near-ties by index: the same poses on every CPU.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sescid.base.lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover - for type checkers; at run time: _EXPORTS
    from sescid.planning.blocks import BlockDesign, schur_logdet, select_blocks
    from sescid.planning.candidates import CandidateOptions, Candidates, candidates
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
    from sescid.planning.double import double_candidates
    from sescid.planning.gantry import (
        GANTRY_LIFT,
        MOUNTS,
        GantryOptions,
        gantry_candidates,
        gantry_floor,
        held_trunk,
        resolve_mount,
        standing_height,
    )
    from sescid.planning.ground import GroundChecks, ground_checks
    from sescid.planning.kinds import (
        DEFAULT_TAU_NOISE,
        DESIGN_KINDS,
        BlockRows,
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
    from sescid.planning.limits import (
        PaperConvention,
        load_paper_convention,
        paper_convention,
        sampling_limits,
        unlimited_joints,
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
    from sescid.planning.plan_types import PlanOptions, PoseCheck, PosePlan, default_candidates
    from sescid.planning.stability import (
        DEFAULT_CLEARANCE,
        FALLBACK_COP_BOX,
        cop_half_extents,
        free_sole,
        ground_clear_mask,
        sole_corners,
        stable_mask,
    )
    from sescid.planning.stances import Stance, parse_stances, stance_robot

__all__ = [
    "DEFAULT_CLEARANCE",
    "DEFAULT_STANCE_COST",
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
    "DesignKinds",
    "GantryOptions",
    "GroundChecks",
    "TorqueRows",
    "PaperConvention",
    "PlanOptions",
    "PoseCheck",
    "PosePlan",
    "Selection",
    "Stance",
    "StancePlan",
    "StanceReport",
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
    "double_candidates",
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
    "parse_stances",
    "path_length",
    "per_row_information",
    "plan_poses",
    "plan_stances",
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
    "stance_robot",
    "select_d_optimal",
    "sole_corners",
    "stable_mask",
    "standing_height",
    "unlimited_joints",
]

#: public name → the module that defines it, imported on first use (``base.lazy``)
_EXPORTS = {
    "compliance": "sescid.planning.compliance",
    "candidates": "sescid.planning.candidates",
    "BlockDesign": "sescid.planning.blocks",
    "BlockRows": "sescid.planning.kinds",
    "CandidateOptions": "sescid.planning.candidates",
    "Candidates": "sescid.planning.candidates",
    "Capsules": "sescid.planning.collision",
    "ComState": "sescid.planning.com",
    "Compliance": "sescid.planning.compliance",
    "DEFAULT_CLEARANCE": "sescid.planning.stability",
    "DEFAULT_STANCE_COST": "sescid.planning.plan_stances",
    "Stance": "sescid.planning.stances",
    "StancePlan": "sescid.planning.plan_stances",
    "StanceReport": "sescid.planning.plan_stances",
    "double_candidates": "sescid.planning.double",
    "parse_stances": "sescid.planning.stances",
    "plan_stances": "sescid.planning.plan_stances",
    "stance_robot": "sescid.planning.stances",
    "DEFAULT_TAU_NOISE": "sescid.planning.kinds",
    "DESIGN_KINDS": "sescid.planning.kinds",
    "DesignKinds": "sescid.planning.kinds",
    "FALLBACK_COP_BOX": "sescid.planning.stability",
    "GANTRY_LIFT": "sescid.planning.gantry",
    "GantryOptions": "sescid.planning.gantry",
    "GroundChecks": "sescid.planning.ground",
    "MOUNTS": "sescid.planning.gantry",
    "PaperConvention": "sescid.planning.limits",
    "PlanOptions": "sescid.planning.plan_types",
    "PoseCheck": "sescid.planning.plan_types",
    "PosePlan": "sescid.planning.plan_types",
    "Selection": "sescid.planning.doptimal",
    "TorqueRows": "sescid.planning.kinds",
    "block_curve": "sescid.planning.plan_kinds",
    "block_rows": "sescid.planning.kinds",
    "box_capsules": "sescid.planning.collision",
    "choose_blocks": "sescid.planning.plan_kinds",
    "collision_capsules": "sescid.planning.collision",
    "collision_free_mask": "sescid.planning.collision",
    "collision_free_mask_numpy": "sescid.planning.collision",
    "com_state": "sescid.planning.com",
    "compliant_margin": "sescid.planning.compliance",
    "cop_half_extents": "sescid.planning.stability",
    "default_candidates": "sescid.planning.plan_types",
    "design_curve": "sescid.planning.plan",
    "design_kinds": "sescid.planning.kinds",
    "dynamic_cop": "sescid.planning.compliance",
    "expected_com_error": "sescid.planning.kinds",
    "expected_cop_error": "sescid.planning.doptimal",
    "first_contact": "sescid.planning.collision",
    "free_sole": "sescid.planning.stability",
    "gantry_candidates": "sescid.planning.gantry",
    "gantry_floor": "sescid.planning.gantry",
    "ground_checks": "sescid.planning.ground",
    "ground_clear_mask": "sescid.planning.stability",
    "held_trunk": "sescid.planning.gantry",
    "identifiable_basis": "sescid.planning.doptimal",
    "information": "sescid.planning.doptimal",
    "kind_basis": "sescid.planning.kinds",
    "level_cop": "sescid.planning.com",
    "load_paper_convention": "sescid.planning.limits",
    "min_block_poses": "sescid.planning.kinds",
    "order_poses": "sescid.planning.ordering",
    "paper_convention": "sescid.planning.limits",
    "path_length": "sescid.planning.ordering",
    "per_row_information": "sescid.planning.doptimal",
    "plan_poses": "sescid.planning.plan",
    "pool_information": "sescid.planning.kinds",
    "projected_regressor": "sescid.planning.doptimal",
    "random_com_error": "sescid.planning.kinds",
    "random_cop_error": "sescid.planning.doptimal",
    "resolve_mount": "sescid.planning.gantry",
    "sampling_limits": "sescid.planning.limits",
    "schur_information": "sescid.planning.kinds",
    "schur_logdet": "sescid.planning.blocks",
    "segment_distance": "sescid.planning.collision",
    "select_blocks": "sescid.planning.blocks",
    "select_d_optimal": "sescid.planning.doptimal",
    "sole_corners": "sescid.planning.stability",
    "stable_mask": "sescid.planning.stability",
    "standing_height": "sescid.planning.gantry",
    "unlimited_joints": "sescid.planning.limits",
}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
