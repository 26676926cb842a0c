"""The sensitivity equations (DDM) and step maps on the C core.

Independent of numba: the C model's sensitivity right-hand side and its outputs'
derivatives against central differences of the C plain model (rhs, outputs) along the same
state, parameter and memory directions. Against numba (the reference, run here): the step
maps bit for bit, and a DDM run, a tangent flow and a return map's monodromy matrix of the
paper case to 1e-10. And a DDM run on the default core loads no numba model module."""

import sys

import numpy as np
import pytest

from mbs_clearance.generate.c_loader import CModel
from mbs_clearance.model import cases
from mbs_clearance.numerics.integrator import METHODS
from mbs_clearance.solve import linkage_ddm
from mbs_clearance.solve import linkage_model as lm
from mbs_clearance.solve.flows import _tangent_scale

NAMES = ("coupler.mass", "coupler_slider.journal_radius", "coupler_slider.restitution",
         "crank.pin.x", "coupler_slider.impact_velocity_floor")


@pytest.fixture(scope="module")
def paper():
    """(linkage, C model, a recorded plain run's ts, ys, ms, p) of the paper case: one
    revolution, with contact and free flight."""
    linkage = cases.paper_slider_crank()
    model = lm.load_model(linkage)
    assert isinstance(model, CModel)
    r = lm.run(linkage, 1, lm.RunSettings(rtol=1e-9))
    return linkage, model, r.ts, r.ys, r.ms, r.p


def _states(ms, n_mem):
    """Indices of two recorded steps: one in contact, one in free flight."""
    contact = np.flatnonzero(ms[:, 0] > 0.5)
    free = np.flatnonzero(ms[:, 0] < 0.5)
    assert len(contact) > 3 and len(free) > 3
    return [int(contact[len(contact) // 2]), int(free[len(free) // 2])]


def _perturbed(model, p_plain, entries, sigma, eps):
    """The plain p moved by eps along a direction's chain (its z columns) and memory
    sensitivities sigma (the impact velocities), constants recomputed."""
    q = p_plain[:model.N_P].copy()
    off = 1 + 2 * model.N_Q
    for c, v in entries.items():
        q[c - off] += eps * v
    q[model.MEM_START + 1:model.MEM_START + 2 * model.N_EVENTS:2] += eps * sigma
    model.prepare(q)
    return q


def test_sensitivity_rhs_and_outputs_match_differences_of_the_plain_model(paper):
    """d(qddot)/db from the C sensitivity right-hand side and d(outputs)/db from
    `output_sensitivities` equal central differences of the C plain model's rhs and outputs
    along the same direction (a random state direction s, the parameter's chain, a random
    memory sensitivity sigma), in contact and in free flight, for parameters of a body, the
    joint's radius (clearance and stiffness), the restitution, a point and the floor."""
    linkage, model, ts, ys, ms, p_plain = paper
    rng = np.random.default_rng(3)
    n, n2, J = model.N_Q, 2 * model.N_Q, model.N_EVENTS
    # every component of a direction at the scale of its quantity's motion in the joint (the
    # journal moves within the clearance): a difference step of 1e-7 of it stays far inside
    # the penetration's range
    unit = _tangent_scale(linkage, model)
    for name in NAMES:
        step = linkage_ddm.fd_step(linkage, name, 1.0)
        entries, _ = linkage_ddm.combine(linkage, model, [{name: step}])
        for i in _states(ms, model.N_MEM):
            p = p_plain.copy()
            p[model.MEM_START:model.MEM_START + model.N_MEM] = ms[i, :model.N_MEM]
            sp = linkage_ddm.pack_sensitivity_parameters(model, p, entries, True)
            s = rng.standard_normal(n2) * unit
            sigma = rng.standard_normal(J) * unit[n2 - 1]
            y = np.concatenate([ys[i, :n2], s, [0.0], sigma])
            rec = model._sens_record(len(sp))
            dydt = np.empty(len(y))
            rec.rhs(ts[i], model._ptr(y), len(y), model._ptr(sp), model._ptr(dydt))
            eps = 1e-7
            rates, outs = [], []
            for sign in (1.0, -1.0):
                q = _perturbed(model, p, entries[0], sigma, sign * eps)
                yq = ys[i].copy()
                yq[:n2] += sign * eps * s
                f = np.empty(model.N_STATE)
                model.rhs(ts[i], yq, q, f)
                rates.append(f[n:n2])
                mq = q[model.MEM_START:model.MEM_START + model.N_MEM][None, :].copy()
                outs.append(model.outputs(ts[i:i + 1], yq[None, :], mq, q)[0])
            fd = (rates[0] - rates[1]) / (2 * eps)
            ddm = dydt[n2 + n:2 * n2]
            assert np.allclose(ddm, fd, rtol=1e-5, atol=1e-6 * np.max(np.abs(fd))), \
                (name, i, ddm, fd)
            assert np.array_equal(dydt[:n2], np.concatenate([ys[i, n:n2], dydt[n:n2]]))
            vals, ders = model.output_sensitivities(ts[i:i + 1], y[None, :],
                                                    p[None, model.MEM_START:
                                                      model.MEM_START + model.N_MEM], sp)
            fd_out = (outs[0] - outs[1]) / (2 * eps)
            big = np.max(np.abs(fd_out))
            assert np.allclose(ders[0, :, 0], fd_out, rtol=1e-5, atol=1e-6 * big), name
            plain = model.outputs(ts[i:i + 1], ys[i:i + 1], ms[i:i + 1, :model.N_MEM], p)[0]
            assert np.allclose(vals[0], plain, rtol=1e-12, atol=1e-12 * np.max(np.abs(plain)))


def _numba(monkeypatch):
    monkeypatch.setenv("MBS_CLEARANCE_CORE", "numba")


def test_step_maps_equal_numba(paper, monkeypatch):
    """refine_steps and step_monitor_value of the C model equal the numba module's bit for
    bit (the same operations in the same order) on recorded steps, for an explicit pair and
    a Rosenbrock method."""
    linkage, model, ts, ys, ms, p = paper
    numba_model = lm.load_numba_model(linkage)
    pn = lm.pack_parameters(linkage, numba_model)
    idx = np.arange(3, len(ts) - 1, max(1, len(ts) // 25))
    y0s, mems = np.ascontiguousarray(ys[idx]), np.ascontiguousarray(ms[idx, :model.N_MEM])
    hs = ts[idx + 1] - ts[idx]
    for method in ("dop853", "rodas4"):
        co = METHODS[method].arrays()
        got = model.refine_steps(ts[idx], y0s, mems, p, hs, co, 12)
        want = numba_model.refine_steps(ts[idx], y0s, mems, pn, hs, co, 12)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
        for k in (0, len(idx) // 2):
            assert model.step_monitor_value(ts[idx[k]], y0s[k], mems[k], p, 0.6 * hs[k], co) \
                == numba_model.step_monitor_value(ts[idx[k]], y0s[k], mems[k], pn,
                                                  0.6 * hs[k], co)


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


@pytest.mark.slow   # the oracle's numba DDM kernels compile for minutes and leave with numba;
# the fast set checks the C sensitivities against differences (above) and pinned values
def test_ddm_tangent_and_monodromy_equal_numba(monkeypatch):
    """The paper case's DDM sensitivities (recorded and at given times), a tangent flow,
    a return map's monodromy matrix and the peak's gradient (steps refined and the DDM
    state stepped to the peak) on the C core equal numba's to 1e-10 relative."""
    from mbs_clearance.analysis.objective import peak_gradient
    from mbs_clearance.analysis.periodic import return_map
    from mbs_clearance.analysis.sensitivity import sensitivities
    from mbs_clearance.solve.flows import Flow, TangentFlow

    linkage = cases.paper_slider_crank()
    names = ("coupler.mass", "coupler_slider.journal_radius", "coupler_slider.restitution",
             "crank.pin.x")
    t_eval = np.linspace(0.0, 0.25 * linkage.period, 7)[1:]

    def runs():
        s = sensitivities(linkage, names, revolutions=1)
        at = sensitivities(linkage, names, revolutions=1, t_eval=t_eval, rtol=1e-10)
        tf = TangentFlow(linkage)
        tf.advance(0.5 * linkage.period)
        f = Flow(linkage)
        n2, J = 2 * f.model.N_Q, f.model.N_EVENTS
        vel = f.p[f.model.MEM_START + 1:f.model.MEM_START + 2 * J:2].copy()
        *_, M = return_map(linkage, f.y[:n2], np.zeros(J), vel, jacobian=True)
        g = peak_gradient(linkage, names[:2], revolution=2)
        return s, at, tf, M, g

    c = runs()
    assert isinstance(c[2].model, CModel)
    _numba(monkeypatch)
    n = runs()
    assert not isinstance(n[2].model, CModel)
    assert np.array_equal(c[0].t, n[0].t)
    assert c[0].stats["nfev"] == n[0].stats["nfev"]
    assert _rel(c[0].base_force, n[0].base_force) < 1e-10
    for name in linkage.coordinates():
        assert _rel(c[0].outputs[name], n[0].outputs[name]) < 1e-10
    assert _rel(c[1].base_force, n[1].base_force) < 1e-10
    assert _rel(c[2].tangent(), n[2].tangent()) < 1e-10
    assert _rel(c[3], n[3]) < 1e-10
    assert _rel(c[4].gradient, n[4].gradient) < 1e-10 and _rel(c[4].peak, n[4].peak) < 1e-10
    assert c[4].time == n[4].time


def test_ddm_run_loads_no_numba_model(monkeypatch):
    """A DDM run and a tangent flow on the default core import no numba model module (no
    generated module loaded, the paper's checked-in one not imported)."""
    from mbs_clearance.analysis.sensitivity import sensitivities
    from mbs_clearance.generate import loader
    from mbs_clearance.model.mechanism import SliderCrank
    from mbs_clearance.solve import reduced
    from mbs_clearance.solve.flows import TangentFlow

    monkeypatch.delenv("MBS_CLEARANCE_CORE", raising=False)
    calls = []
    original = loader.load_model
    monkeypatch.setattr(loader, "load_model", lambda *a, **k: calls.append(a) or original(*a, **k))
    original_paper = reduced._numba_model
    monkeypatch.setattr(reduced, "_numba_model",
                        lambda: calls.append("paper") or original_paper())
    before = {m for m in sys.modules if m.startswith("mbs_clearance._generated.")}
    sensitivities(cases.paper_slider_crank(), ("coupler.mass", "slider.mass"), revolutions=1)
    sensitivities(SliderCrank(), ("slider_mass",), revolutions=1)
    TangentFlow(cases.paper_slider_crank()).advance(0.01)
    after = {m for m in sys.modules if m.startswith("mbs_clearance._generated.")}
    assert calls == [] and after == before, (calls, after - before)


def test_sensitivity_calls_check_their_arrays(paper):
    """A plain p, or a state of another length than its directions need, is refused with a
    one-line error before any computation (the C code would read past them)."""
    linkage, model, ts, ys, ms, p = paper
    entries, _ = linkage_ddm.combine(linkage, model, [{"coupler.mass": 1.0}])
    sp = linkage_ddm.pack_sensitivity_parameters(model, p.copy(), entries, True)
    n_state = 2 * model.N_Q * 2 + 1 + model.N_EVENTS
    y = np.zeros(n_state)
    mem = ms[:1, :model.N_MEM]
    co = METHODS["dop853"].arrays()
    with pytest.raises(ValueError, match="sensitivity run's parameter vector"):
        model.output_sensitivities(ts[:1], y[None, :], mem, p)
    with pytest.raises(ValueError, match=f"must have {n_state} entries for 1 directions"):
        model.output_sensitivities(ts[:1], y[None, :-1], mem, sp)
    with pytest.raises(ValueError, match=f"must have {n_state} entries"):
        model.step_sens(ts[0], y[:-1], sp, np.array([1e-4]), co)
    with pytest.raises(ValueError, match="does not fit its header"):
        model.integrate_sens(y, sp[:-1].copy(), np.array([0.0, 1e-3]), None, co)


def test_without_a_compiler_the_ddm_runs_on_numba_after_one_warning(monkeypatch):
    """No C compiler: a DDM run's model is the numba module, after one warning naming what
    to install (and none for the next run)."""
    from mbs_clearance._warnings import MbsClearanceWarning
    from mbs_clearance.generate import c_loader
    from mbs_clearance.solve import kernels

    monkeypatch.delenv("MBS_CLEARANCE_CORE", raising=False)
    monkeypatch.setenv("CC", "no-such-compiler-xyz")
    monkeypatch.setattr(c_loader, "_LOADED", {})
    monkeypatch.setattr(kernels, "_WARNED", set())
    linkage = cases.paper_slider_crank()
    with pytest.warns(MbsClearanceWarning, match="install gcc") as record:
        model = linkage_ddm.plain_setup(linkage, None)[0]
        again = linkage_ddm.plain_setup(linkage, None)[0]
    assert len(record) == 1
    assert not isinstance(model, CModel) and again is model
    assert callable(model.integrate_sens)
