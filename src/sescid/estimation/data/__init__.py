"""What was measured, as rows: one measurement record of any kind and stance, the rows each kind
makes, where chunks come from, the checks at the boundary."""

#: the sub-package's modules (imported where used: no import here)
__all__ = [
    "anchor",
    "balance_rows",
    "checks",
    "measurements",
    "sources",
    "torque_rows",
]
