"""Ambrosio's modified Coulomb law: Ft = -mu Fn c_d(|vt|) sign(vt) with the dynamic
correction coefficient c_d = 0 for |vt| <= v0, (|vt| - v0) / (v1 - v0) between, 1 for
|vt| >= v1 (Ambrosio 2002, "Impact of rigid and flexible multibody systems: deformation
description and contact models", in Virtual Nonlinear Multibody Systems, NATO Sci. Ser. II
103; used for clearance joints by Flores, Ambrosio, Claro & Lankarani, "Kinematics and
Dynamics of Multibody Systems with Imperfect Joints", Springer 2008). It has no stiction:
below v0 the joint is frictionless."""

from ..base import FrictionLaw
from ..ops import fabs, sign, where
from ._common import MU, V0, V1


def force(vt, fn, mu, v0, v1):
    """Ft."""
    speed = fabs(vt)
    s = sign(vt)
    phi = where(speed <= v0, 0.0, where(speed >= v1, s, s * (speed - v0) / (v1 - v0)))
    return -mu * fn * phi


LAW = FrictionLaw(name="ambrosio", force=force,
                  arguments=("friction_coefficient", "friction_v0", "friction_v1"),
                  parameters=(MU, V0, V1), source="Ambrosio 2002, NATO Sci. Ser. II 103; "
                  "Flores, Ambrosio, Claro & Lankarani 2008, Springer")
