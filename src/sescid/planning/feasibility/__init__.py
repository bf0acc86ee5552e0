"""Which poses a robot can hold: joint limits, static stability, ground clearance, self-
collision, compliance, closed chains, candidate draws."""

#: the sub-package's modules (imported where used: no import here)
__all__ = [
    "adjust",
    "broadphase",
    "candidates",
    "capsule_kernels",
    "closure",
    "closure_kernels",
    "collision",
    "com",
    "compliance",
    "double",
    "gantry",
    "ground",
    "limits",
    "stability",
]
