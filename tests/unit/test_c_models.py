"""The generated C models against the numba modules of the same structures (the oracle):
for every named case, specialised and general, the kernels called through the function
pointers of the C model's record agree with the numba kernels at random states, parameter
perturbations, contact modes and laws: rhs, event, on_event's memory update, monitor (its
value, dydt, outputs, g, gd) and prepare's constants."""

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


@pytest.mark.parametrize("specialise", [True, False], ids=["specialised", "general"])
def test_c_kernels_agree_with_numba(case, specialise):
    """Metadata equal, prepare's constants and every kernel's values within RTOL of the
    numba module's at TRIALS random points (the largest difference is recorded)."""
    lk = CASES[case]
    mod = load_model(lk, specialise)
    cm = load_c_model(lk, specialise)
    k = _Kernels(cm)
    for name in ("PARAMETERS", "OUT_COLUMNS", "COORDINATES", "JOINTS", "FRICTION_JOINTS",
                 "GROUND_JOINTS", "ZERO_PARAMETERS"):
        assert tuple(getattr(mod, name)) == tuple(getattr(cm, name)), name
    for name in ("N_STATE", "N_Q", "N_EVENTS", "MEM_START", "N_MEM", "N_OUT", "CONST_START",
                 "MONITOR_COLUMN", "MOMENT_COLUMN", "ACC_COLUMN", "FRICTION_WORK",
                 "MONITOR_JOINT"):
        assert getattr(mod, name) == getattr(cm, name), name
    assert list(mod.ZERO_INDEX) == list(cm.ZERO_INDEX)
    rec = cm.record
    assert (rec.n_state, rec.n_q, rec.n_events, rec.mem_start, rec.n_mem, rec.n_out,
            rec.const_start, rec.n_p) == (cm.N_STATE, cm.N_Q, cm.N_EVENTS, cm.MEM_START,
                                          cm.N_MEM, cm.N_OUT, cm.CONST_START, cm.N_P)
    # the C model's constants are the first of the numba module's (which adds its
    # Jacobians' after them)
    assert cm.CONST_START < cm.N_P <= mod.N_P

    p0 = pack_parameters(lk, mod)
    y0 = initial_state(lk, mod, p0)
    clearance = min(p0[i] for i, nm in enumerate(mod.PARAMETERS) if nm.endswith(".clearance"))
    scale = max(lk.length_scale, 1e-300)
    zeros = set(mod.ZERO_PARAMETERS)
    rng = np.random.default_rng(20261128)
    n, N, J = mod.N_Q, mod.N_STATE, mod.N_EVENTS
    worst = {}

    def seen(what, a, b):
        r = _rel(a, b)
        worst[what] = max(worst.get(what, 0.0), r)

    contacts = 0
    for trial in range(TRIALS):
        p = _perturbed(rng, mod, p0, zeros, wide=trial % 4 == 3)
        mod.prepare(p)
        pc = p[:cm.N_P].copy()
        pc[cm.CONST_START:] = np.nan
        assert k.prepare(pc) == 0
        # the kernels' constants (the C model's closure adds its own after them)
        kc = cm.CONST_START + cm.N_KERNEL_CONSTANTS
        seen("prepare", pc[cm.CONST_START:kc], p[cm.CONST_START:kc])
        y = _state(rng, mod, y0, clearance, scale)
        t = rng.uniform(0.0, 0.2)
        for m in sorted({2 * n, 2 * n + 1, N}):
            d_nb = np.full(m, np.nan)
            mod.rhs(t, y, p, d_nb)
            seen("rhs", k.rhs(t, y, p, m), d_nb)
        for j in range(J):
            seen("event", k.event(t, y, p, j), mod.event(t, y, p, j))
            q_nb, q_c = p.copy(), p.copy()
            mod.on_event(t, y, q_nb, j)
            k.on_event(t, y, q_c, j)
            seen("on_event", q_c[mod.MEM_START:mod.MEM_START + 2 * J],
                 q_nb[mod.MEM_START:mod.MEM_START + 2 * J])
            assert np.array_equal(q_c[:mod.MEM_START], p[:mod.MEM_START])
        for n_out in (mod.N_OUT, 0):
            dydt, out = np.full(N, np.nan), np.full(max(n_out, 1), np.nan)
            g, gd = np.empty(J), np.empty(J)
            m_nb = mod.monitor(t, y, p, dydt, out, g, gd)
            m_c, dydt_c, out_c, g_c, gd_c = k.monitor(t, y, p, N, n_out)
            seen("monitor", m_c, m_nb)
            seen("monitor dydt", dydt_c, dydt)
            seen("monitor g, gd", np.r_[g_c, gd_c], np.r_[g, gd])
            if n_out:
                seen("outputs", out_c, out)
                contacts += int(np.any(out_c[0:5 * J:5] > 0.0))
            else:
                assert np.isnan(out_c).all() and np.isnan(out).all()
    MAX_SEEN[f"{case} {'specialised' if specialise else 'general'}"] = max(worst.values())
    print(case, specialise, {w: f"{v:.2e}" for w, v in worst.items()})
    assert contacts > TRIALS // 10, "too few random states in contact to compare the laws"
    assert all(v <= RTOL for v in worst.values()), worst


def test_c_prepare_refuses_a_specialised_zero_that_is_not_zero():
    """prepare returns 1 when a parameter the model is specialised on is not zero (the
    numba module raises)."""
    lk = CASES["paper_slider_crank"]
    mod, cm = load_model(lk), load_c_model(lk)
    p = pack_parameters(lk, mod)[:cm.N_P].copy()
    k = _Kernels(cm)
    assert k.prepare(p) == 0
    p[mod.ZERO_INDEX[0]] = 1e-3
    assert k.prepare(p) == 1
    with pytest.raises(ValueError, match="specialised"):
        mod.prepare(np.r_[p, np.zeros(mod.N_P - cm.N_P)])




def test_c_source_is_kept_and_a_damaged_copy_is_generated_again(tmp_path, monkeypatch):
    """A model's C source is derived once and read back from the cache by the next process
    (counted); a damaged copy is never compiled: a CacheWarning, then the source again."""
    from mbs_clearance.generate import c_loader

    monkeypatch.setenv("MBS_CLEARANCE_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(c_loader, "_LOADED", {})
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
