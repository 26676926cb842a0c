"""The sensitivity equations (DDM) and step maps on the C core.

The C model's sensitivity right-hand side and its outputs' derivatives against central
differences of the C plain model (rhs, outputs) along the same state, parameter and memory
directions; the step maps against the run's recorded steps and sampled values. The whole
DDM runs, tangents, monodromy matrices and peak gradients are checked against central
differences of plain runs in tests/unit/test_linkage_ddm.py, test_periodic.py and
test_objective.py."""

import numpy as np
import pytest

from mbs_clearance.generate.c_loader import CModel
from mbs_clearance.model import cases
from mbs_clearance.numerics.integrator import METHODS
from mbs_clearance.solve import linkage_ddm
from mbs_clearance.solve import linkage_model as lm
from mbs_clearance.solve.flows import _tangent_scale, prepare_flow

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
    unit = _tangent_scale(prepare_flow(linkage))
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


def test_step_maps_retake_the_recorded_steps_and_find_their_maxima(paper):
    """step_monitor_value over a whole recorded step gives the monitored force the run
    recorded at its end (the integrator's own step, re-taken), and refine_steps' maximum
    over a step is at least every value of the step map sampled inside it, at a time
    inside the step, for an explicit pair; a Rosenbrock method's maximum is also inside
    its step and at least its ends."""
    linkage, model, ts, ys, ms, p = paper
    r = lm.run(linkage, 1, lm.RunSettings(rtol=1e-9))
    force = np.hypot(r.outs[:, model.MONITOR_COLUMN], r.outs[:, model.MONITOR_COLUMN + 1])
    idx = np.arange(3, len(ts) - 1, max(1, len(ts) // 25))
    idx = idx[ts[idx + 1] > ts[idx]]
    y0s, mems = np.ascontiguousarray(ys[idx]), np.ascontiguousarray(ms[idx, :model.N_MEM])
    hs = ts[idx + 1] - ts[idx]
    co = METHODS["dopri5"].arrays()
    for k in range(len(idx)):
        end = model.step_monitor_value(ts[idx[k]], y0s[k], mems[k], p, hs[k], co)
        # round-off: the step map and the integrator's own step order their operations
        # differently (measured: up to 1.2e-11 relative over a revolution's steps)
        assert end == pytest.approx(force[idx[k] + 1], rel=1e-10)
    fractions = np.linspace(0.0, 1.0, 11)[1:]
    for method in ("dop853", "rodas4"):
        co = METHODS[method].arrays()
        # 40 golden-section iterations: the maximum's time to 0.618^40 = 4e-9 of the step
        vals, times = model.refine_steps(ts[idx], y0s, mems, p, hs, co, 40)
        assert np.all(times >= ts[idx]) and np.all(times <= ts[idx] + hs)
        for k in range(0, len(idx), 5):
            grid = fractions if method == "dop853" else fractions[-1:]
            sampled = max(model.step_monitor_value(ts[idx[k]], y0s[k], mems[k], p, f * hs[k],
                                                   co) for f in grid)
            # within the search's resolution (a maximum at the step's end: its slope times
            # 4e-9 of the step)
            assert vals[k] >= sampled * (1.0 - 1e-9), (method, k)


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


def test_without_a_compiler_a_ddm_run_stops_with_one_line_naming_what_to_install(
        monkeypatch):
    """No C compiler: a DDM run stops before any computation with one line naming the
    compilers looked for and what to install."""
    from mbs_clearance.core.build import CompilerMissing
    from mbs_clearance.generate import c_loader

    monkeypatch.setenv("CC", "no-such-compiler-xyz")
    monkeypatch.setattr(c_loader, "_LOADED", {})
    linkage = cases.paper_slider_crank()
    with pytest.raises(CompilerMissing, match="no-such-compiler-xyz.*install gcc") as err:
        linkage_ddm.prepare_sensitivity(linkage, ("crank.mass",), 1)
    assert "\n" not in str(err.value)
