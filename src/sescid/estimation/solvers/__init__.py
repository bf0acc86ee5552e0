"""The methods that turn the sums into a fit: least squares, MAP, robust, online, physically
consistent masses, and the auto choice."""

#: the sub-package's modules (imported where used: no import here)
__all__ = [
    "api",
    "consistent",
    "gains",
    "least_squares",
    "map",
    "map_prior",
    "online",
    "options",
    "payload",
    "payload_rows",
    "robust",
    "runs",
    "solve",
    "torque_noise",
]
