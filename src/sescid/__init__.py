"""sescid: identify a humanoid robot's mass distribution from centre-of-pressure measurements."""

from .errors import SescidError
from .estimate import Fit, identify, identify_stream
from .io import load_fit
from .robot import Robot, load_robot
from .simulate import simulate

__all__ = [
    "Fit",
    "Robot",
    "SescidError",
    "identify",
    "identify_stream",
    "load_fit",
    "load_robot",
    "simulate",
]
__version__ = "0.1.0"
