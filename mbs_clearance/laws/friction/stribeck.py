"""Stribeck friction: the friction coefficient falls from the static mu_s at rest to the
dynamic mu_d over the Stribeck velocity v_s,

    mu(v) = mu_d + (mu_s - mu_d) exp(-(|v| / v_s)^2),
    Ft = -Fn mu(vt) vt / sqrt(vt^2 + v0^2),

the sign of vt regularised over v0 as in the regularised Coulomb law (Andersson, Söderberg
& Björklund 2007, "Friction models for sliding dry, boundary and mixed lubricated
contacts", Tribol. Int. 40:580, the Stribeck curve with the Gaussian exponent 2; reviewed
by Pennestrì, Rossi, Salvini & Valentini 2016, Nonlinear Dyn. 83:1785). With mu_s = mu_d
it is the regularised Coulomb law."""

from ..base import FrictionLaw, Parameter
from ..ops import exp, sqrt
from ._common import MU, V0

MU_S = Parameter("friction_static_coefficient", "mu_s", "-", 0.0, 0.0,
                 source="0: give the pair's static coefficient (>= friction_coefficient, the "
                        "dynamic one, for the Stribeck law)")
V_S = Parameter("friction_stribeck_velocity", "v_s", "m/s", 1e-3, 0.0, low_open=True,
                source="assumed: an order of magnitude above the default regularisation "
                       "velocity v0; the paper's joint is frictionless and gives none; give "
                       "the pair's value")


def force(vt, fn, mu, v0, mu_s, v_s):
    """Ft."""
    ratio = vt / v_s
    coefficient = mu + (mu_s - mu) * exp(-(ratio * ratio))
    return -fn * coefficient * (vt / sqrt(vt * vt + v0 * v0))


def check(what, values):
    """The law's own condition on its parameters: mu_s >= mu_d (the friction coefficient
    falls from rest)."""
    if values["friction_static_coefficient"] < values["friction_coefficient"]:
        raise ValueError(
            f"{what} friction_static_coefficient must be >= friction_coefficient = "
            f"{values['friction_coefficient']!r} with friction_law 'stribeck' (the static "
            f"coefficient is at least the dynamic one); got "
            f"{values['friction_static_coefficient']!r}")


LAW = FrictionLaw(name="stribeck", force=force,
                  arguments=("friction_coefficient", "friction_v0",
                             "friction_static_coefficient", "friction_stribeck_velocity"),
                  parameters=(MU, V0, MU_S, V_S), check=check,
                  source="Andersson, Söderberg & Björklund 2007, Tribol. Int. 40:580; "
                         "Pennestrì et al. 2016, Nonlinear Dyn. 83:1785")
