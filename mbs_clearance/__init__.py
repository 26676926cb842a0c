"""mbs-clearance: planar mechanisms with clearance joints.

Public API::

    from mbs_clearance import SliderCrank, simulate, sensitivities, optimize_link_lengths
    traj = simulate(SliderCrank(), revolutions=4, backend="reduced")
    sens = sensitivities(SliderCrank(), ["crank_length", "slider_mass"], method="ddm")
    opt = optimize_link_lengths(SliderCrank(), seed=1)
"""

import logging

from ._warnings import (  # noqa: F401 - public warning classes, users filter by them
    AccuracyWarning,
    CacheWarning,
    MbsClearanceWarning,
    PhysicsWarning,
)

# messages (e.g. "compiling core ...") go to the logger "mbs_clearance" at INFO; they are
# shown only where the application configures logging (the CLI does)
logging.getLogger(__name__).addHandler(logging.NullHandler())

#: public name -> submodule that defines it; imported on first use (PEP 562), so that
#: `import mbs_clearance` and the CLI's start-up load only what a command needs
_LAZY = {
    **dict.fromkeys(("GROUND", "Body", "ClearanceJoint", "Drive", "Initial", "Linkage",
                     "Prismatic", "Revolute"), "model.linkage"),
    **dict.fromkeys(("LyapunovResult", "lyapunov_exponent"), "analysis.lyapunov"),
    **dict.fromkeys(("Start", "settled_start"), "solve.linkage_model"),
    "RunSettings": "solve.settings",
    **dict.fromkeys(("CONTINUOUS_FIELDS", "PARAMETER_INFO", "SliderCrank"), "model.mechanism"),
    **dict.fromkeys(("PeakGradient", "peak_gradient"), "analysis.objective"),
    **dict.fromkeys(("OptimizationResult", "optimize_link_lengths"), "studies.optimize"),
    **dict.fromkeys(("PoincareSection", "poincare_section"), "analysis.poincare"),
    **dict.fromkeys(("DEFAULT_PARAMETERS", "Sensitivities", "sensitivities"),
                    "analysis.sensitivity"),
    **dict.fromkeys(("BACKENDS", "peak_base_force", "simulate"), "solve.simulate"),
    **dict.fromkeys(("MapResult", "regime_map"), "studies.sweep"),
    **dict.fromkeys(("ToleranceResult", "tolerance_study", "Uniform", "Normal", "FitClearance",
                     "ToleranceProblem"), "studies.tolerance"),
    **dict.fromkeys(("WearResult", "wear_life"), "studies.wear"),
    "BearingProfile": "model.profile",
    **dict.fromkeys(("CASES", "paper_slider_crank", "paper_slider_crank_lubricated",
                     "paper_slider_crank_wear", "slider_crank_two_clearances", "four_bar",
                     "flores_translational_slider_crank"), "model.cases"),
    "ExudynSettings": "backends.exudyn_linkage",
    "Problem": "solve.problem",
    **dict.fromkeys(("Trajectory", "load_trajectory"), "solve.trajectory"),
    **dict.fromkeys(("PeriodicOrbit", "periodic_orbit", "Branch", "continue_orbits"),
                    "analysis.periodic"),
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


__all__ = [
    "SliderCrank", "PARAMETER_INFO", "CONTINUOUS_FIELDS",
    "Linkage", "Body", "Revolute", "Prismatic", "ClearanceJoint", "Drive", "Initial", "GROUND",
    "simulate", "peak_base_force", "BACKENDS", "RunSettings", "Start", "settled_start",
    "Trajectory", "load_trajectory",
    "sensitivities", "Sensitivities", "DEFAULT_PARAMETERS",
    "optimize_link_lengths", "OptimizationResult",
    "peak_gradient", "PeakGradient",
    "tolerance_study", "ToleranceResult", "ToleranceProblem", "Uniform", "Normal",
    "FitClearance",
    "CASES", "paper_slider_crank", "paper_slider_crank_lubricated", "paper_slider_crank_wear",
    "slider_crank_two_clearances", "four_bar", "flores_translational_slider_crank",
    "ExudynSettings", "Problem",
    "poincare_section", "PoincareSection", "lyapunov_exponent", "LyapunovResult",
    "regime_map", "MapResult",
    "wear_life", "WearResult", "BearingProfile",
    "periodic_orbit", "PeriodicOrbit", "continue_orbits", "Branch",
    "MbsClearanceWarning", "AccuracyWarning", "PhysicsWarning", "CacheWarning",
]

def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("mbs-clearance")
    except PackageNotFoundError:  # a source tree that was never installed
        return "unknown"

