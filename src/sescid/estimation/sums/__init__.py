"""One accumulator: the normal equations of any mix of kinds, in memory, streamed or pooled over
stances, and the residual pass."""

#: the sub-package's modules (imported where used: no import here)
__all__ = [
    "block_sums",
    "distinct",
    "normal_equations",
    "pooled",
    "residual_sums",
    "system",
]
