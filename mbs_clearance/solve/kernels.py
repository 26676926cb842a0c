"""The compiled model of a run: the C core (`mbs_clearance.core`: the integrator compiled
once for every model, each model's kernels, its Jacobian and tangent and its sensitivity
equations printed in C and compiled in seconds), for plain, sensitivity (DDM) and tangent
runs alike.

Where no C compiler is found the first run stops with one line naming what to install
(`core.build.CompilerMissing`).
"""

from __future__ import annotations

__all__ = ["c_model", "plain_kernel"]


def c_model(linkage, specialise: bool = True):
    """The compiled C model of `linkage` (`generate.c_loader.CModel`), specialised on its
    zero-valued geometric parameters unless `specialise` is False."""
    from ..generate.c_loader import load_c_model

    return load_c_model(linkage, specialise)


def plain_kernel(linkage, model, specialise: bool = True):
    """A callable with the signature ``integrate_model(y0, p, edges, settings,
    coefficients)`` that runs `model` (`linkage`'s C model) on the compiled core."""
    return model.integrate_model
