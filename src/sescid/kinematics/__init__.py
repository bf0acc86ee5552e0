"""Kinematics: rotations and origins of every body relative to the support frame, for n poses at
once, and the regressor products built on them.

The chain runs block by block in structure-of-arrays layout, its inner loops across poses;
sin/cos come from a polynomial kernel (``trig``). Each body's joint contributes

    M_b(θ) = C_b Rot(a_b, θ) = A0_b + sin θ · A1_b + (1 − cos θ) · A2_b,   θ = coef_b q_j + off_b

with A0 = C, A1 = C K, A2 = C K² and K the cross-product matrix of the axis (Rodrigues).
Modules: ``tree`` (the flat arrays), ``compile`` (numba loaded on first use, and which jobs
run in numpy before it), ``trig``, ``chains`` (the chain: kernel beside its numpy twin), ``cop``
(x, y of the CoM of many poses), ``reduced`` (the regressor without its structural null space)
and ``fused`` (normal equations in one pass).
"""

from __future__ import annotations

from sescid.kinematics.chains import (
    CHAIN_BLOCK,
    Workspace,
    chain,
    com_one,
    forward,
    regressor,
    regressor_columns,
)
from sescid.kinematics.compile import compiled, lazy_njit, loaded
from sescid.kinematics.cop import cop_xy, cop_xy_compiled
from sescid.kinematics.fused import GRAM_BLOCK, gram_reduced, gram_upper, padded
from sescid.kinematics.reduced import Reduction, reduced_columns, reduction
from sescid.kinematics.tree import Tree, as_poses
from sescid.kinematics.trig import MAX_ANGLE, SMALL_ANGLE

__all__ = [
    "CHAIN_BLOCK",
    "GRAM_BLOCK",
    "MAX_ANGLE",
    "SMALL_ANGLE",
    "Reduction",
    "Tree",
    "Workspace",
    "as_poses",
    "chain",
    "com_one",
    "compiled",
    "cop_xy",
    "cop_xy_compiled",
    "forward",
    "gram_reduced",
    "gram_upper",
    "lazy_njit",
    "loaded",
    "padded",
    "reduced_columns",
    "reduction",
    "regressor",
    "regressor_columns",
]
