"""Which feasible poses tell most: the rows each kind gives, one D-optimal engine over blocks of
rows, sequential choice, stances' shared parameters."""

#: the sub-package's modules (imported where used: no import here)
__all__ = [
    "block_kernels",
    "blocks",
    "doptimal",
    "doptimal_kernels",
    "kinds",
    "payload",
    "sequential",
    "stances",
]
