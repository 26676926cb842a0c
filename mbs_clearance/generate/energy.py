"""The mechanical energy of a linkage's model, evaluated in Python from its derivation: a
check of the compiled model (energy balances, the drive's power as the energy's rate), not
part of a run.

`mechanical_energy(linkage)` returns ``energy(t, y, p)`` in J: kinetic plus gravitational
energy of the state y (its leading 2 N_Q entries: coordinates and rates), plus the contact
springs' energy K delta^2.5 / 2.5 of every contact in contact mode (the mode read from the
memory in p), with p the compiled model's parameter vector (its leading PARAMETERS entries
are read; the constants after them are not). The expressions come from `derive.derive`
(sympy, once per structure and process) and are evaluated with numpy.
"""

from __future__ import annotations

import threading

from ..elements.registry import ELEMENTS
from ..model.linkage import Linkage
from .key import model_structure, structure_digest

__all__ = ["mechanical_energy"]


def mechanical_energy(linkage: Linkage):
    """``energy(t, y, p)`` in J of `linkage`'s model (see the module docstring); t in s, y
    and p 1-d float arrays (the compiled model's state and parameter vector)."""
    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    digest = structure_digest(model_structure(linkage, False))
    with _LOCK:
        if digest not in _ENERGIES:
            _ENERGIES[digest] = _energy(linkage)
        return _ENERGIES[digest]


_LOCK = threading.Lock()
_ENERGIES: dict = {}


def _energy(linkage: Linkage):
    import sympy as sp

    from .derive import derive

    d = derive(linkage)
    params = list(d.parameters)
    n = len(d.Q)
    psyms = [d.psyms[name] for name in params]
    angles = {S: sp.sin(a) for a, S, _ in d.angles} | {C: sp.cos(a) for a, _, C in d.angles}
    args = [d.t, *d.Q, *d.U, *psyms]

    def numeric(expr):
        return sp.lambdify(args, sp.sympify(expr).xreplace(angles), modules="math")

    body = numeric(d.kinetic + d.potential)
    # per contact its offsets (x, y)
    offsets = ([numeric(g[0]) for g in d.gaps], [numeric(g[1]) for g in d.gaps])
    mem_start = params.index(f"{d.events[0]}.mode")
    elements, first = [], 0
    for el in ELEMENTS:
        elements.append(el.contact_energy(d.parts[el.kind], params, first, offsets))
        first += len(d.parts[el.kind].contacts)

    def energy(t, y, p):
        a = [float(t), *(float(v) for v in y[:2 * n]), *(float(v) for v in p[:len(params)])]
        e = body(*a)
        for contact_energy in elements:
            e += contact_energy(a, p, mem_start)
        return e

    return energy
