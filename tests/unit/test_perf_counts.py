"""The plain run's cost pinned by counts, and the written-out dopri5 step
equal, bit for bit, to the generic step it replaces (docs/performance.md, "Where the time
goes")."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest

from mbs_clearance import SliderCrank
from mbs_clearance.numerics import integrator
from mbs_clearance.numerics.integrator import METHODS
from mbs_clearance.solve import reduced

MODEL = reduced.MODEL


def test_only_dopri5_takes_the_written_out_step():
    assert integrator._is_dopri5(*METHODS["dopri5"].arrays()[:4], METHODS["dopri5"].E2,
                                 METHODS["dopri5"].A_extra)
    for name in ("dop853", "bs3"):
        tab = METHODS[name]
        assert not integrator._is_dopri5(tab.A, tab.B, tab.C, tab.E, tab.E2, tab.A_extra)
    # one coefficient changed in its last bit: the generic step
    tab = METHODS["dopri5"]
    A = tab.A.copy()
    A[4, 2] = np.nextafter(A[4, 2], 0.0)
    assert not integrator._is_dopri5(A, tab.B, tab.C, tab.E, tab.E2, tab.A_extra)


@nb.njit(cache=False)
def _both_steps(ts, hs, ys, ms, p, atol, rtol, n_err, coefficients):
    """Each state's step by the generic `_step_monitor` + `error_norm` and by the written-out
    `_dp5_step_monitor` + `_dp5_error`: the largest |difference| of every result (0: equal)
    and the number of results that differ in any bit."""
    A, B, C, E, E2, P, A_extra, C_extra, eo, pa, pb = coefficients
    n = ys.shape[1]
    f = np.empty(n)
    K1 = np.zeros((7, n))
    K2 = np.zeros((7, n))
    y1 = np.empty(n)
    y2 = np.empty(n)
    f1 = np.empty(n)
    f2 = np.empty(n)
    tmp = np.empty(n)
    w1 = np.empty(n)
    w2 = np.empty(n)
    out1 = np.empty(MODEL.N_OUT)
    out2 = np.empty(MODEL.N_OUT)
    g1 = np.empty(1)
    g2 = np.empty(1)
    gd1 = np.empty(1)
    gd2 = np.empty(1)
    y = np.empty(n)
    differ = 0
    for i in range(ts.shape[0]):
        for k in range(n):
            y[k] = ys[i, k]
        p[MODEL.MEM_START] = ms[i, 0]
        p[MODEL.MEM_START + 1] = ms[i, 1]
        MODEL.rhs(ts[i], y, p, f)
        m1 = integrator._step_monitor(MODEL.rhs, MODEL.monitor, ts[i], y, f, hs[i], A, B, C,
                                      K1, p, y1, f1, tmp, out1, g1, gd1)
        e1 = integrator.error_norm(K1, E, E2, hs[i], y, y1, rtol, atol, n_err, w1, w1)
        m2 = integrator._dp5_step_monitor(MODEL.rhs, MODEL.monitor, ts[i], y, f, hs[i], K2,
                                          p, y2, f2, tmp, out2, g2, gd2)
        e2 = integrator._dp5_error(K2, hs[i], y, y2, rtol, atol, n_err, w2)
        if m1 != m2 or e1 != e2 or g1[0] != g2[0] or gd1[0] != gd2[0]:
            differ += 1
        for k in range(n):
            if y1[k] != y2[k] or f1[k] != f2[k]:
                differ += 1
            for r in range(7):
                if K1[r, k] != K2[r, k]:
                    differ += 1
        for k in range(n_err):
            if w1[k] != w2[k]:
                differ += 1
        for k in range(MODEL.N_OUT):
            if out1[k] != out2[k]:
                differ += 1
    return differ


def test_written_out_dopri5_step_equals_the_generic_step_bit_for_bit():
    """Independent reference: the generic tableau-driven step (`_step_monitor`,
    `error_norm`), on 400 states and step sizes of the paper case's run, free flight and
    contact."""
    mech = SliderCrank()
    ts, ys, ms, *_, p = reduced.run(mech, 1, record=True)
    idx = np.linspace(0, len(ts) - 2, 400).astype(int)
    hs = np.ascontiguousarray(ts[idx + 1] - ts[idx])
    assert np.any(ms[idx, 0] > 0.5) and np.any(ms[idx, 0] < 0.5)   # both modes covered
    atol = np.append(reduced.default_atol(mech, 1e-7), reduced.event_atol(mech, 1e-7))
    differ = _both_steps(np.ascontiguousarray(ts[idx]), hs, np.ascontiguousarray(ys[idx]),
                         np.ascontiguousarray(ms[idx, :2]), p.copy(), atol, 1e-7,
                         reduced.N_ERR, METHODS["dopri5"].arrays())
    assert differ == 0


def test_paper_case_cost_counts():
    """The paper case's default run (4 revolutions, rtol 1e-7): its rev-4 peak, function
    evaluations, steps, events and refined steps; a change of any count changes the run's
    cost (or its result) and must be explained. The event search's margin is 0.001 c
    (`linkage_model.event_margin`); with 0.05 c the approach step limit near the onsets and
    separations differs: 8291.958246907485 N, 59911, 9711 + 255 (both within 9.3e-7 of the
    rtol 1e-12 run's peak, the difference 2.3e-9). The model is specialised on its
    zero-valued geometric parameters (the journal's gap 3 + 2 + 3 + 2 terms instead of
    6 + 6 + 5 + 5): the same counts as the general model, the peak 8291.958273534865 N
    against 8291.95826563021 N (round-off of the shorter sums, 9.5e-10; the run's error
    against rtol 1e-12 is 9.3e-7)."""
    traj = reduced.simulate_reduced(SliderCrank(), 4)
    s = traj.stats
    assert (s["nfev"], s["naccept"], s["nreject"], s["nevent"], s["nrefine"]) == (
        59959, 9712, 261, 5, 23)
    assert traj.peaks[-1] == pytest.approx(8291.958273534865, rel=1e-12)


@pytest.mark.slow
def test_paper_case_kernel_calls():
    """The kernels' calls in the peak-only run (the integrator specialised for counting
    wrappers: a compile of minutes): per attempted step (9973) five rhs and one monitor
    (plus the landing steps' and the initial step's); the switching function once per
    attempt (the embedded solution's, for its error control) and once per accepted step
    (the event search's interior sample), plus the closer looks and the landings (170; 361
    with a margin of 0.05 c, in 9966 attempts)."""
    from benchmarks.cost_breakdown import counts

    c = counts()
    attempts = c["naccept"] + c["nreject"]
    assert attempts == 9973
    assert c["main"] == {"rhs": 50111, "event": 19855, "on_event": 5, "monitor": 10005}
    assert c["main"]["event"] == attempts + c["naccept"] + 170
    # nfev counts the main loop's calls but one refined step's (1 + 26 x 6 = 157): a
    # window's last step is refined on p itself, where the wrappers count it
    assert c["main"]["rhs"] + c["main"]["monitor"] == c["nfev"] + 157
    assert c["refine"] == {"rhs": 3013, "monitor": 598}
