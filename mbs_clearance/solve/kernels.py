"""Which compiled integrator runs a model: the C core or numba's.

The C core (`mbs_clearance.core`: the integrator compiled once for every model, each model's
kernels, its Jacobian and tangent and its sensitivity equations printed in C and compiled in
seconds) is the default, for plain, sensitivity (DDM) and tangent runs alike. numba's
integrator, specialised per model and kind of run, stays as the reference;
``MBS_CLEARANCE_CORE=numba`` selects it for every run. Both give the same numbers to
round-off (tests/unit/test_core_oracle.py, tests/unit/test_c_sensitivities.py).

Where no C compiler is found the run goes on with numba, after one warning naming what to
install.
"""

from __future__ import annotations

import os
import warnings
from functools import partial

from .._warnings import MbsClearanceWarning

__all__ = ["ENV", "CORES", "core_name", "plain_kernel"]

#: the environment variable that chooses the core of every run
ENV = "MBS_CLEARANCE_CORE"
CORES = ("c", "numba")
_WARNED = set()


def core_name() -> str:
    """The core of every run: ``$MBS_CLEARANCE_CORE`` ("c", the default, or "numba")."""
    name = os.environ.get(ENV, "c").strip().lower() or "c"
    if name not in CORES:
        raise ValueError(f"{ENV} must be one of {list(CORES)}; got {name!r}")
    return name


def c_model_or_none(linkage, specialise: bool = True):
    """The compiled C model of `linkage` when the C core is chosen (None: numba is, or no C
    compiler was found, after one warning naming what to install)."""
    if core_name() == "numba":
        return None
    from ..core.build import CompilerMissing
    from ..generate.c_loader import load_c_model

    try:
        return load_c_model(linkage, specialise)
    except CompilerMissing as err:
        if "compiler" not in _WARNED:
            _WARNED.add("compiler")
            warnings.warn(f"{err}; running on numba's integrator meanwhile (it compiles "
                          "for a minute on first use)", MbsClearanceWarning, stacklevel=3)
        return None


def plain_kernel(linkage, model, specialise: bool = True):
    """A callable with the signature of a generated module's ``integrate_model(y0, p, edges,
    settings, coefficients)`` that runs `model` (a C model, or the numba module of
    `linkage`: then its parameter vector is translated for the C model) on the chosen
    core."""
    from ..generate.c_loader import CModel

    if isinstance(model, CModel):
        return model.integrate_model
    c_model = c_model_or_none(linkage, specialise)
    if c_model is None:
        return model.integrate_model
    return partial(_run_c, c_model)


def _run_c(c_model, y0, p, edges, settings, coefficients):
    """The C model's run from a numba module's parameter vector `p`: the parameters and
    memory of `p`, then the C kernels' own constants (fewer than the numba module's); the
    memory copied back into `p` afterwards, as the numba kernel leaves it."""
    import numpy as np

    start, mem, n_mem = c_model.CONST_START, c_model.MEM_START, c_model.N_MEM
    pc = np.empty(c_model.N_P)
    pc[:start] = p[:start]
    c_model.prepare(pc)
    out = c_model.integrate_model(y0, pc, edges, settings, coefficients)
    p[mem:mem + n_mem] = pc[mem:mem + n_mem]
    return out
