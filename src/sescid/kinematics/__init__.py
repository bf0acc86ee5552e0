"""Kinematics: rotations and origins of every body relative to the support frame, for n poses at
once, and the regressor products built on them.

The chain runs block by block in structure-of-arrays layout, its inner loops across poses;
sin/cos come from a polynomial kernel. Each body's joint contributes

    M_b(θ) = C_b Rot(a_b, θ) = A0_b + sin θ · A1_b + (1 − cos θ) · A2_b,   θ = coef_b q_j + off_b

with A0 = C, A1 = C K, A2 = C K² and K the cross-product matrix of the axis (Rodrigues).
Modules: ``tree`` (the flat arrays), ``compile`` (numba loaded on first use, and which jobs
run in numpy: by their size alone) and the private ``_kernels`` package (each compiled kernel
beside its numpy twin: the chain, the CoM's x, y, the reduced columns, the normal equations'
products of the CoP and the joint torques, holding torques and a fit's residual pass), whose
public names are these.
"""

from sescid.kinematics._kernels.chains import (
    CHAIN_BLOCK,
    Workspace,
    chain,
    com_one,
    forward,
    regressor,
)
from sescid.kinematics._kernels.cop import com_rows, com_sum, cop_xy
from sescid.kinematics._kernels.fused import (
    GRAM_BLOCK,
    add_gram_reduced,
    augmented_size,
    gram_reduced,
    reduced_order,
    split_augmented,
)
from sescid.kinematics._kernels.gram import LANES, gram_columns, gram_numpy, padded
from sescid.kinematics._kernels.reduced import Reduction, reduced_columns, reduction
from sescid.kinematics._kernels.residuals import cop_residual_sums, torque_residual_sums
from sescid.kinematics._kernels.torque_plan import TorquePlan, torque_plan
from sescid.kinematics._kernels.torque_sums import (
    TorqueBlock,
    add_gram_fused,
    fold_torque,
    gram_fused,
    torque_size,
)
from sescid.kinematics._kernels.torque_values import torque_rows, torque_values
from sescid.kinematics._kernels.trig import MAX_ANGLE, SMALL_ANGLE, reducible
from sescid.kinematics.compile import (
    NUMPY_JOB,
    cache_folder,
    compiled,
    counting_compiles,
    lazy_njit,
    load_kernels,
    loaded,
    prefer_kernels,
    use_kernels,
)
from sescid.kinematics.tree import Tree, as_poses

__all__ = [
    "LANES",
    "CHAIN_BLOCK",
    "GRAM_BLOCK",
    "MAX_ANGLE",
    "NUMPY_JOB",
    "SMALL_ANGLE",
    "Reduction",
    "TorqueBlock",
    "TorquePlan",
    "Tree",
    "Workspace",
    "add_gram_fused",
    "add_gram_reduced",
    "as_poses",
    "augmented_size",
    "cache_folder",
    "chain",
    "com_one",
    "com_rows",
    "com_sum",
    "compiled",
    "cop_residual_sums",
    "cop_xy",
    "counting_compiles",
    "fold_torque",
    "forward",
    "gram_columns",
    "gram_fused",
    "gram_numpy",
    "gram_reduced",
    "lazy_njit",
    "load_kernels",
    "loaded",
    "padded",
    "prefer_kernels",
    "reduced_columns",
    "reduced_order",
    "reducible",
    "reduction",
    "regressor",
    "split_augmented",
    "torque_plan",
    "torque_residual_sums",
    "torque_rows",
    "torque_size",
    "torque_values",
    "use_kernels",
]
