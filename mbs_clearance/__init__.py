"""mbs-clearance: slider-crank mechanisms with a revolute clearance joint.

Public API::

    from mbs_clearance import SliderCrank, simulate, sensitivities, optimize_link_lengths
    traj = simulate(SliderCrank(), revolutions=4, backend="reduced")
    sens = sensitivities(SliderCrank(), ["crank_length", "slider_mass"], method="ddm")
    opt = optimize_link_lengths(SliderCrank(), seed=1)
"""

from ._cache import register_package
from ._warnings import (  # noqa: F401 - public warning classes, users filter by them
    AccuracyWarning,
    CacheWarning,
    MbsClearanceWarning,
    PhysicsWarning,
)

# before any kernel is defined: cache the kernels under a digest of all the package's sources
# as imported (numba alone does not notice edits of the files a kernel calls into; _cache.py)
register_package(__name__)

from .linkage import (  # noqa: E402
    GROUND,
    Body,
    ClearanceJoint,
    Drive,
    Linkage,
    Prismatic,
    Revolute,
)
from .lyapunov import LyapunovResult, lyapunov_exponent  # noqa: E402
from .mechanism import CONTINUOUS_FIELDS, PARAMETER_INFO, SliderCrank  # noqa: E402
from .objective import PeakGradient, peak_gradient  # noqa: E402
from .optimize import OptimizationResult, optimize_link_lengths  # noqa: E402
from .poincare import PoincareSection, poincare_section  # noqa: E402
from .sensitivity import DEFAULT_PARAMETERS, Sensitivities, sensitivities  # noqa: E402
from .simulate import BACKENDS, peak_base_force, simulate  # noqa: E402
from .sweep import MapResult, regime_map  # noqa: E402
from .tolerance import ToleranceResult, tolerance_study  # noqa: E402
from .trajectory import Trajectory, load_trajectory  # noqa: E402

__all__ = [
    "SliderCrank", "PARAMETER_INFO", "CONTINUOUS_FIELDS",
    "Linkage", "Body", "Revolute", "Prismatic", "ClearanceJoint", "Drive", "GROUND",
    "simulate", "peak_base_force", "BACKENDS",
    "Trajectory", "load_trajectory",
    "sensitivities", "Sensitivities", "DEFAULT_PARAMETERS",
    "optimize_link_lengths", "OptimizationResult",
    "peak_gradient", "PeakGradient",
    "tolerance_study", "ToleranceResult",
    "poincare_section", "PoincareSection", "lyapunov_exponent", "LyapunovResult",
    "regime_map", "MapResult",
    "MbsClearanceWarning", "AccuracyWarning", "PhysicsWarning", "CacheWarning",
]

def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("mbs-clearance")
    except PackageNotFoundError:  # a source tree that was never installed
        return "unknown"


__version__ = _version()
