"""Pictures of spline surfaces: shaded, zebra, curvature, deviation, control net."""
from .core import *  # noqa: F401,F403
from .core import __all__, _pyvista_usable  # noqa: F401
