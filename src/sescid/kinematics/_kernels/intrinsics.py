"""Stand-ins for the SIMD intrinsics of ``simd`` (which imports numba and llvmlite), one per
intrinsic: a kernel module imports those it calls by name, and ``compile.load_group`` swaps each
for the real intrinsic, in every module of the group, before any kernel compiles."""

from sescid.kinematics.compile import simd_intrinsic

fma = simd_intrinsic("fma")
vabs = simd_intrinsic("vabs")
vabsmax = simd_intrinsic("vabsmax")
vadd = simd_intrinsic("vadd")
vfma = simd_intrinsic("vfma")
vload = simd_intrinsic("vload")
vmaxlane = simd_intrinsic("vmaxlane")
vmul = simd_intrinsic("vmul")
vneg = simd_intrinsic("vneg")
vsplat = simd_intrinsic("vsplat")
vstore = simd_intrinsic("vstore")
vsub = simd_intrinsic("vsub")
vsum = simd_intrinsic("vsum")
vzero = simd_intrinsic("vzero")

__all__ = [
    "fma",
    "vabs",
    "vabsmax",
    "vadd",
    "vfma",
    "vload",
    "vmaxlane",
    "vmul",
    "vneg",
    "vsplat",
    "vstore",
    "vsub",
    "vsum",
    "vzero",
]
