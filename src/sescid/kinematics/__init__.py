"""Kinematics: rotations and origins of every body relative to the support frame, for n poses at
once, and the regressor products built on them.

The chain runs block by block in structure-of-arrays layout, its inner loops across poses;
sin/cos come from a polynomial kernel (``trig``). Each body's joint contributes

    M_b(θ) = C_b Rot(a_b, θ) = A0_b + sin θ · A1_b + (1 − cos θ) · A2_b,   θ = coef_b q_j + off_b

with A0 = C, A1 = C K, A2 = C K² and K the cross-product matrix of the axis (Rodrigues).
Modules: ``tree`` (the flat arrays), ``compile`` (numba loaded on first use, and which jobs
run in numpy: by their size alone), ``simd`` (explicit FMAs and 8-lane vectors: the same bits on
every CPU), ``trig`` and ``trig_fma``, ``chains`` (the chain: kernel beside its numpy twin),
``cop`` (x, y of the CoM of many poses), ``reduced`` (the regressor without its structural null
space), ``gram`` (sums of products in a fixed order), ``fused`` (the CoP's normal equations in one
pass), ``torque_plan``, ``torque`` and ``torque_sums`` (the joint torques' normal equations in the
same pass), ``torque_values`` (holding torques and their regressor rows) and ``residuals`` (a
fit's residual pass).
"""

from sescid.kinematics.chains import (
    CHAIN_BLOCK,
    Workspace,
    chain,
    com_one,
    forward,
    regressor,
    regressor_columns,
)
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
from sescid.kinematics.cop import com_rows, com_sum, cop_xy
from sescid.kinematics.fused import GRAM_BLOCK, augmented_size, gram_reduced, split_augmented
from sescid.kinematics.gram import gram_columns, gram_numpy, padded
from sescid.kinematics.reduced import Reduction, reduced_columns, reduction
from sescid.kinematics.tree import Tree, as_poses
from sescid.kinematics.trig import MAX_ANGLE, SMALL_ANGLE, reducible

__all__ = [
    "CHAIN_BLOCK",
    "GRAM_BLOCK",
    "MAX_ANGLE",
    "NUMPY_JOB",
    "SMALL_ANGLE",
    "Reduction",
    "Tree",
    "Workspace",
    "as_poses",
    "augmented_size",
    "cache_folder",
    "chain",
    "com_one",
    "com_rows",
    "com_sum",
    "compiled",
    "cop_xy",
    "counting_compiles",
    "forward",
    "gram_columns",
    "gram_numpy",
    "gram_reduced",
    "lazy_njit",
    "load_kernels",
    "loaded",
    "padded",
    "prefer_kernels",
    "reduced_columns",
    "reducible",
    "reduction",
    "regressor",
    "regressor_columns",
    "split_augmented",
    "use_kernels",
]
