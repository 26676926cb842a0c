"""mbs-clearance: slider-crank mechanisms with a revolute clearance joint.

Public API::

    from mbs_clearance import SliderCrank, simulate, sensitivities, optimize_link_lengths
    traj = simulate(SliderCrank(), revolutions=4, backend="reduced")
    sens = sensitivities(SliderCrank(), ["crank_length", "slider_mass"], method="ddm")
    opt = optimize_link_lengths(SliderCrank(), seed=1)
"""

import logging
import sys
import types

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

# messages (e.g. "compiling kernels ...") go to the logger "mbs_clearance" at INFO; they are
# shown only where the application configures logging (the CLI does)
logging.getLogger(__name__).addHandler(logging.NullHandler())

#: public name -> submodule that defines it; imported on first use (PEP 562), so that
#: `import mbs_clearance` and the CLI's start-up load only what a command needs
_LAZY = {
    **dict.fromkeys(("GROUND", "Body", "ClearanceJoint", "Drive", "Linkage", "Prismatic",
                     "Revolute"), "linkage"),
    **dict.fromkeys(("LyapunovResult", "lyapunov_exponent"), "lyapunov"),
    **dict.fromkeys(("Start", "settled_start"), "linkage_model"),
    **dict.fromkeys(("CONTINUOUS_FIELDS", "PARAMETER_INFO", "SliderCrank"), "mechanism"),
    **dict.fromkeys(("PeakGradient", "peak_gradient"), "objective"),
    **dict.fromkeys(("OptimizationResult", "optimize_link_lengths"), "optimize"),
    **dict.fromkeys(("PoincareSection", "poincare_section"), "poincare"),
    **dict.fromkeys(("PeriodicOrbit", "periodic_orbit", "Branch", "continue_orbits"),
                    "periodic"),
    **dict.fromkeys(("DEFAULT_PARAMETERS", "Sensitivities", "sensitivities"), "sensitivity"),
    **dict.fromkeys(("BACKENDS", "peak_base_force", "simulate"), "simulate"),
    **dict.fromkeys(("MapResult", "regime_map"), "sweep"),
    **dict.fromkeys(("ToleranceResult", "tolerance_study"), "tolerance"),
    **dict.fromkeys(("Trajectory", "load_trajectory"), "trajectory"),
}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        if name == "__version__":
            value = _version()
            globals()[name] = value
            return value
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY) | {"__version__"})


class _Package(types.ModuleType):
    """The package's module type: importing the submodule `simulate` (mbs_clearance/
    simulate.py) must not replace the public function `simulate` of the same name, which the
    import system would otherwise do (it sets the parent's attribute to the submodule)."""

    def __setattr__(self, name, value):
        if (isinstance(value, types.ModuleType) and value.__name__ == f"{__name__}.{name}"
                and _LAZY.get(name) == name):
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


__all__ = [
    "SliderCrank", "PARAMETER_INFO", "CONTINUOUS_FIELDS",
    "Linkage", "Body", "Revolute", "Prismatic", "ClearanceJoint", "Drive", "GROUND",
    "simulate", "peak_base_force", "BACKENDS", "Start", "settled_start",
    "Trajectory", "load_trajectory",
    "sensitivities", "Sensitivities", "DEFAULT_PARAMETERS",
    "optimize_link_lengths", "OptimizationResult",
    "peak_gradient", "PeakGradient",
    "tolerance_study", "ToleranceResult",
    "poincare_section", "PoincareSection", "lyapunov_exponent", "LyapunovResult",
    "regime_map", "MapResult",
    "periodic_orbit", "PeriodicOrbit", "continue_orbits", "Branch",
    "MbsClearanceWarning", "AccuracyWarning", "PhysicsWarning", "CacheWarning",
]

def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("mbs-clearance")
    except PackageNotFoundError:  # a source tree that was never installed
        return "unknown"

