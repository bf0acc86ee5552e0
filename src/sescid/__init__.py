"""sescid: identify a humanoid robot's mass distribution from centre-of-pressure measurements."""

from .errors import SescidError
from .robot import Robot, load_robot

__all__ = ["Robot", "SescidError", "load_robot"]
__version__ = "0.1.0"
