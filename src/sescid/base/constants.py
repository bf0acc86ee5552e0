"""Physical constants every layer uses: standard gravity."""

#: standard gravity [m/s²] (the one home of g0: weights, kgf, the torque bound)
G0 = 9.80665
