"""The generated C models: for every named case, specialised and general, the kernels
called through the function pointers of the C model's record against the derivation
evaluated by sympy (free flight); a specialised model refuses a nonzero zero; the C source
cache; names that are C words. The contact laws in C are checked against their Python
formulas in tests/unit/test_c_jacobians.py, the contact-mode right-hand side by the energy
balances (tests/unit/test_generate.py, tests/unit/test_translational.py)."""

import json

import numpy as np
import pytest

from mbs_clearance._warnings import CacheWarning
from mbs_clearance.generate import NAMED_VARIANTS, load_model
from mbs_clearance.generate.c_loader import generate_c_module, load_c_model
from mbs_clearance.laws.lubrication import MODELS as LUBRICATION_MODELS
from mbs_clearance.laws.registry import CONTACT, FRICTION
from mbs_clearance.model import cases
from mbs_clearance.model.linkage import Linkage
from mbs_clearance.solve.linkage_model import initial_state, pack_parameters

#: relative agreement of every compared value (the contract is 1e-12 for a whole run; the
#: kernels evaluate the same operations in the same order, so they agree to round-off)
RTOL = 1e-13
TRIALS = 200

CASES = {name: fn() for name, fn in cases.CASES.items()}
CASES.update({name: getattr(cases, case)(**over) for name, (case, over) in
              NAMED_VARIANTS.items()})
# the translational benchmark with friction at its corners
CASES["flores_translational_slider_crank_friction"] = cases.flores_translational_slider_crank(
    friction_law="coulomb", friction_coefficient=0.1)
MAX_SEEN: dict[str, float] = {}


def _rel(a, b) -> float:
    """The largest |a - b| / max(|a|, |b|) (0 where both are 0)."""
    a, b = np.atleast_1d(np.asarray(a, float)), np.atleast_1d(np.asarray(b, float))
    assert a.shape == b.shape
    assert np.array_equal(np.isfinite(a), np.isfinite(b))
    fin = np.isfinite(a)
    den = np.maximum(np.abs(a[fin]), np.abs(b[fin]))
    diff = np.abs(a[fin] - b[fin])
    return float(np.max(np.where(den > 0, diff / np.where(den > 0, den, 1.0), 0.0),
                        initial=0.0))


class _Kernels:
    """The C model's kernels through its record's function pointers, numpy in and out."""

    def __init__(self, cm):
        self.cm, self.ffi, self.rec = cm, cm.ffi, cm.record

    def ptr(self, a):
        return self.ffi.from_buffer("double[]", a)

    def rhs(self, t, y, p, n):
        dydt = np.full(n, np.nan)
        self.rec.rhs(t, self.ptr(y), n, self.ptr(p), self.ptr(dydt))
        return dydt

    def event(self, t, y, p, j):
        g = np.empty(2)
        self.rec.event(t, self.ptr(y), self.ptr(p), j, self.ptr(g))
        return g

    def on_event(self, t, y, p, j):
        self.rec.on_event(t, self.ptr(y), self.ptr(p), j)

    def monitor(self, t, y, p, n, n_out):
        dydt, out = np.full(n, np.nan), np.full(max(n_out, 1), np.nan)
        J = self.cm.N_EVENTS
        g, gd = np.empty(J), np.empty(J)
        m = self.rec.monitor(t, self.ptr(y), n, self.ptr(p), self.ptr(dydt), self.ptr(out),
                             n_out, self.ptr(g), self.ptr(gd))
        return m, dydt, out, g, gd

    def prepare(self, p):
        return self.rec.prepare(self.ptr(p))


def _is_geometry(name: str) -> bool:
    tail = name.rsplit(".", 1)[-1]
    return tail in ("x", "y", "clearance", "half_height", "half_length", "angle",
                    "slider_angle", "journal_radius", "bearing_radius", "initial_angle")


def _perturbed(rng, mod, p0, zeros, wide):
    """p0 with its physical parameters scaled by up to 10 % (geometry by 1e-7 relative, or
    1e-3 when `wide`: the journals then leave the film's range), random laws, modes and
    impact velocities; the specialised zeros kept."""
    p = p0[:mod.CONST_START].copy()
    names = mod.PARAMETERS
    for i, name in enumerate(names):
        tail = name.rsplit(".", 1)[-1]
        if name in zeros or tail in ("mode", "impact_velocity"):
            continue
        if tail == "contact_model":
            p[i] = float(rng.integers(len(CONTACT)))
        elif tail == "friction_law":
            p[i] = float(rng.integers(len(FRICTION)))
        elif tail == "lubrication":
            p[i] = float(rng.integers(len(LUBRICATION_MODELS)))
        elif tail == "restitution":
            p[i] = rng.uniform(0.3, 1.0)
        elif _is_geometry(name):
            p[i] *= 1.0 + rng.uniform(-1, 1) * (1e-3 if wide else 1e-7)
            if p[i] == 0.0 and not zeros:
                p[i] = rng.uniform(-1, 1) * 1e-4
        else:
            p[i] *= 1.0 + 0.1 * rng.uniform(-1, 1)
    for j in range(mod.N_EVENTS):
        k = mod.MEM_START + 2 * j
        p[k] = float(rng.integers(2))
        p[k + 1] = rng.uniform(0.01, 2.0)
    full = np.zeros(mod.N_P)
    full[:mod.CONST_START] = p
    return full


def _state(rng, mod, y0, clearance, scale):
    """y0 moved by a few clearances (angles over the length scale) with random rates."""
    y = y0.copy()
    n = mod.N_Q
    for i, c in enumerate(mod.COORDINATES):
        y[i] += rng.uniform(-3, 3) * clearance / (scale if c.endswith(".angle") else 1.0)
    y[n:2 * n] += rng.uniform(-1, 1, n) * (np.abs(y0[n:2 * n]) + 1.0) * 0.3
    y[2 * n:] = rng.uniform(-1, 1, mod.N_STATE - 2 * n)
    return y


@pytest.fixture(scope="module", params=sorted(CASES), ids=str)
def case(request):
    return request.param


@pytest.fixture(scope="module")
def derivation(case):
    """(the derivation of `case`'s structure, numeric functions of it: the mass matrix, the
    forcing and the contacts' offsets (ex, ey, exd, eyd) with every contact force zero, of
    (t, q, u, parameters))."""
    import sympy as sp

    from mbs_clearance.generate.derive import derive

    d = derive(CASES[case])
    angles = {S: sp.sin(a) for a, S, _ in d.angles} | {C: sp.cos(a) for a, _, C in d.angles}
    forces = d.load_symbols
    free = angles | dict.fromkeys(forces, 0.0)
    args = [d.t, *d.Q, *d.U, *(d.psyms[name] for name in d.parameters)]

    def numeric(expr):
        return sp.lambdify(args, sp.Matrix(expr).xreplace(free), modules="numpy")

    return d, numeric(d.mass_matrix), numeric(d.forcing), numeric(sp.Matrix(d.gaps))


@pytest.mark.parametrize("specialise", [True, False], ids=["specialised", "general"])
def test_c_kernels_agree_with_the_derivation(case, specialise, derivation):
    """The C model's kernels against its derivation evaluated by sympy (numpy, no constants
    split off, no common subexpressions, no specialisation): in free flight (every contact
    in free flight, the films without viscosity: every contact force zero) at TRIALS random
    states and parameters, the accelerations of rhs and of the monitor are M^-1 f and the
    contacts' offsets and rates (`gap`) are the derivation's, to round-off; the metadata
    match the record, prepare leaves the parameters alone."""
    lk = CASES[case]
    d, mass, forcing, gaps = derivation
    cm = load_c_model(lk, specialise)
    k = _Kernels(cm)
    rec = cm.record
    assert (rec.n_state, rec.n_q, rec.n_events, rec.mem_start, rec.n_mem, rec.n_out,
            rec.const_start, rec.n_p) == (cm.N_STATE, cm.N_Q, cm.N_EVENTS, cm.MEM_START,
                                          cm.N_MEM, cm.N_OUT, cm.CONST_START, cm.N_P)
    assert tuple(cm.PARAMETERS) == tuple(d.parameters)
    assert tuple(cm.COORDINATES) == tuple(d.coordinates)
    p0 = pack_parameters(lk, cm)
    y0 = initial_state(lk, cm, p0)
    clearance = min(p0[i] for i, nm in enumerate(cm.PARAMETERS) if nm.endswith(".clearance"))
    scale = max(lk.length_scale, 1e-300)
    zeros = set(cm.ZERO_PARAMETERS)
    rng = np.random.default_rng(20261128)
    n, N, J = cm.N_Q, cm.N_STATE, cm.N_EVENTS
    worst = {}
    for trial in range(TRIALS // 10):
        p = _perturbed(rng, cm, p0, zeros, wide=trial % 4 == 3)
        for i, name in enumerate(cm.PARAMETERS):
            if name.endswith((".mode", ".viscosity")):
                p[i] = 0.0
        before = p[:cm.CONST_START].copy()
        assert k.prepare(p) == 0
        assert np.array_equal(p[:cm.CONST_START], before)
        y = _state(rng, cm, y0, clearance, scale)
        t = rng.uniform(0.0, 0.2)
        a = (float(t), *y[:2 * n], *p[:cm.CONST_START])
        want = np.linalg.solve(np.asarray(mass(*a), float),
                               np.asarray(forcing(*a), float).ravel())
        acc = k.rhs(t, y, p, N)[n:2 * n]
        _, dydt, _, _, _ = k.monitor(t, y, p, N, cm.N_OUT)
        offsets = np.asarray(gaps(*a), float).reshape(-1, 4)
        for what, got, ref in (("rhs", acc, want), ("monitor", dydt[n:2 * n], want),
                               *((f"gap {j}", cm.gap(t, y, p, j), offsets[j])
                                 for j in range(J))):
            # against the largest term: accelerations cancel between large terms
            err = np.max(np.abs(np.asarray(got) - ref)) / max(np.max(np.abs(ref)), 1e-300)
            worst[what.split()[0]] = max(worst.get(what.split()[0], 0.0), err)
    print(case, specialise, {w: f"{v:.2e}" for w, v in worst.items()})
    # the same expressions in another order of operations: round-off of the largest term
    assert all(v <= 1e-12 for v in worst.values()), worst


def test_c_prepare_refuses_a_specialised_zero_that_is_not_zero():
    """prepare returns 1 when a parameter the model is specialised on is not zero;
    `CModel.prepare` raises, naming the general model."""
    lk = CASES["paper_slider_crank"]
    cm = load_c_model(lk)
    p = pack_parameters(lk, cm)
    k = _Kernels(cm)
    assert k.prepare(p) == 0
    p[cm.ZERO_INDEX[0]] = 1e-3
    assert k.prepare(p) == 1
    with pytest.raises(ValueError, match="specialised"):
        cm.prepare(p)


def test_c_source_is_kept_and_a_damaged_copy_is_generated_again(tmp_path, monkeypatch):
    """A model's C source is derived once and read back from the cache by the next process
    (counted); a damaged copy is never compiled: a CacheWarning, then the source again."""
    from mbs_clearance.generate import c_loader

    monkeypatch.setenv("MBS_CLEARANCE_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(c_loader, "_LOADED", {})
    # the cache alone: the four-bar's shipped source set aside
    monkeypatch.setattr(c_loader, "SHIPPED", tmp_path / "none")
    calls = []
    real = c_loader._render
    monkeypatch.setattr(c_loader, "_render", lambda *a: calls.append(a) or real(*a))
    lk = CASES["four_bar"]
    first = c_loader.load_c_model(lk)
    assert len(calls) == 1
    c_loader._LOADED.clear()                 # as a new process
    again = c_loader.load_c_model(lk)
    assert len(calls) == 1 and again.source == first.source and again.meta == first.meta
    kept = next(tmp_path.glob("model-source-*.json"))
    kept.write_text(kept.read_text().replace("sqrt(", "cbrt("))
    c_loader._LOADED.clear()
    with pytest.warns(CacheWarning, match="does not match its recorded digest"):
        third = c_loader.load_c_model(lk)
    assert len(calls) == 2 and third.source == first.source
    assert "cbrt(" not in third.source


def test_c_model_of_names_that_are_c_words():
    """Names of the description that are C keywords, library functions or the generator's
    own names never reach the code: the model compiles and computes what the same linkage
    with plain names computes; distinctive names appear nowhere in the source."""
    lk = CASES["paper_slider_crank"]
    text = json.dumps(lk.to_dict())
    for old, new in (("coupler_slider", "sqrt"), ("crank", "int"), ("coupler", "res"),
                     ("slider", "P0")):
        text = text.replace(f'"{old}', f'"{new}')
    odd = Linkage.from_dict(json.loads(text))
    plain, cm = load_c_model(lk), load_c_model(odd)
    assert plain.N_P == cm.N_P and cm.PARAMETERS != plain.PARAMETERS
    p = pack_parameters(lk, load_model(lk))[:cm.N_P].copy()
    q = p.copy()
    assert _Kernels(plain).prepare(p) == 0 and _Kernels(cm).prepare(q) == 0
    assert _rel(q, p) <= RTOL
    y = initial_state(lk, load_model(lk)) + 1e-5
    a, b = _Kernels(plain).rhs(0.01, y, p, plain.N_STATE), _Kernels(cm).rhs(0.01, y, p,
                                                                            cm.N_STATE)
    assert np.array_equal(a, b)
    source = generate_c_module(cases.paper_slider_crank())
    for name in ("crank", "coupler", "slider", "gravity", "drive", "mass", "stiffness"):
        assert name not in source
