"""mbs-clearance: slider-crank mechanisms with a revolute clearance joint.

Public API::

    from mbs_clearance import SliderCrank, simulate
    traj = simulate(SliderCrank(), revolutions=4, backend="reduced")
"""

from .mechanism import CONTINUOUS_FIELDS, PARAMETER_INFO, SliderCrank
from .sensitivity import DEFAULT_PARAMETERS, Sensitivities, sensitivities
from .simulate import BACKENDS, peak_base_force, simulate
from .trajectory import Trajectory, load_trajectory

__all__ = [
    "SliderCrank", "PARAMETER_INFO", "CONTINUOUS_FIELDS",
    "simulate", "peak_base_force", "BACKENDS",
    "Trajectory", "load_trajectory",
    "sensitivities", "Sensitivities", "DEFAULT_PARAMETERS",
]

__version__ = "0.1.0"
