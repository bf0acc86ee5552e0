"""The kinematics kernels (private: ``sescid.kinematics`` is their public face): each compiled
numba kernel beside its numpy twin (the same operations in the same order where the twin must
give the kernel's bits) and the Python function that picks the path.

Modules: ``trig`` and ``trig_fma`` (sin θ, 1 − cos θ), ``chains`` (rotations and origins of a
block of poses, the regressor, the one-pose CoM), ``cop`` (the CoM's x, y of many poses),
``reduced`` (the regressor without its structural null space), ``gram`` (sums of products in a
fixed order), ``fused`` (the CoP's normal equations in one pass), ``torque_plan``, ``torque`` and
``torque_sums`` (the joint torques' normal equations in the same pass), ``torque_values``
(holding torques and their regressor rows), ``residuals`` (a fit's residual pass), ``simd``
(explicit FMAs and 8-lane vectors, loaded with numba when the kernels load: not imported here)
and ``intrinsics`` (its stand-ins until then).
Names are public within the package: a kernel module imports another's by its plain name.
"""

from sescid.kinematics._kernels import (
    chains,
    cop,
    fused,
    gram,
    intrinsics,
    reduced,
    residuals,
    torque,
    torque_plan,
    torque_sums,
    torque_values,
    trig,
    trig_fma,
)

__all__ = [
    "chains",
    "cop",
    "fused",
    "gram",
    "intrinsics",
    "reduced",
    "residuals",
    "torque",
    "torque_plan",
    "torque_sums",
    "torque_values",
    "trig",
    "trig_fma",
]
