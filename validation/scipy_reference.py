"""The reduced model's equations integrated by `scipy.integrate.solve_ivp`, with events.

An independent integrator for the same equations: scipy steps, locates the contact onset and
separation with its own event machinery (terminal events, restart with the memory updated),
and the peaks of |F12| are refined on scipy's dense output. Shares only the right-hand side
and the contact-mode update with the compiled integrator. `solve_scipy` takes the paper's
`SliderCrank` (its generated model, with the SliderCrank's tolerances and start),
`solve_scipy_linkage` any `Linkage` (its generated model, one terminal event per clearance
joint).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from mbs_clearance.core.integrate import RecordKernels
from mbs_clearance.model.mechanism import SliderCrank
from mbs_clearance.numerics.integrator import N_CRESTS
from mbs_clearance.solve import reduced

__all__ = ["ScipyResult", "solve_scipy", "solve_scipy_linkage"]


@dataclass
class ScipyResult:
    """Peaks per window, segments between events and solver counts."""

    edges: np.ndarray
    peaks: np.ndarray
    peak_times: np.ndarray
    event_times: np.ndarray
    nfev: int
    segments: list  # (t_start, t_end, OdeSolution, p snapshot)
    monitored: object = None  # monitored(t, y, p): the force whose peaks are taken

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """State and parameter vector (memory) at time t from the dense output."""
        for t0, t1, sol, p in self.segments:
            if t0 <= t <= t1:
                return sol(t), p
        raise ValueError(f"t = {t} outside the solution")


def solve_scipy(mech: SliderCrank, edges: np.ndarray | None = None, revolutions: int = 4,
                method: str = "DOP853", rtol: float = 1e-12,
                atol: np.ndarray | None = None) -> ScipyResult:
    """The paper's slider-crank (its generated model, reduced.MODEL, as the compiled runs)
    integrated with solve_ivp from edges[0] to edges[-1]; max |F12| per window."""
    if edges is None:
        edges = reduced.window_edges(mech, revolutions)
    atol = reduced.default_atol(mech, rtol) if atol is None else atol
    model = reduced.MODEL
    p = reduced.model_parameters(mech)
    # the switching function is offset by the round-off of the penetration (a difference of
    # coordinates of size L2 + L3): a state located on the surface may come out a few ulps
    # on the far side in the new mode, and scipy, which looks only for sign changes between
    # step ends, would then miss a crossing in the first step after the restart (seen after
    # a separation: the journal flew through the wall)
    offset = max(1e-12 * mech.clearance,
                 8 * np.finfo(float).eps * (mech.crank_length + mech.coupler_length))
    return _solve(model.rhs, model.event, RecordKernels(model).on_event, _monitored(model),
                  reduced.initial_state(mech), p, edges, 1, offset, method, rtol, atol)


def _monitored(model):
    """monitored(t, y, p): the model's monitored force (its monitor's value)."""
    dydt = np.empty(model.N_STATE)
    out, g, gd = np.empty(0), np.empty(model.N_EVENTS), np.empty(model.N_EVENTS)
    kernels = RecordKernels(model)

    def monitored(tt, yy, pp):
        return kernels.monitor(tt, yy, pp, dydt, out, g, gd)

    return monitored


def solve_scipy_linkage(linkage, revolutions: int = 4, method: str = "DOP853",
                        rtol: float = 1e-12, atol: np.ndarray | None = None) -> ScipyResult:
    """The model generated from `linkage` (a `Linkage`) integrated by solve_ivp over
    `revolutions` drive revolutions from the centred start: the same compiled right-hand
    side, switching functions (one terminal event per clearance joint) and mode switch
    (`on_event`) as the compiled integrator, scipy's own stepping, event location and
    dense output. Peaks of the monitored force per revolution, refined on the dense output.
    atol: per state component (default: the compiled integrator's, the drive's work not
    under error control, as there)."""
    from mbs_clearance.generate import load_model
    from mbs_clearance.solve.linkage_model import default_atol, initial_state, pack_parameters

    model = load_model(linkage)
    p = pack_parameters(linkage, model)
    y0 = initial_state(linkage, model, p)
    if atol is None:
        atol = default_atol(linkage, model, rtol)[:model.N_STATE].copy()
        atol[2 * model.N_Q:] = np.inf          # the drive's work: a quadrature, no control
    edges = np.arange(revolutions + 1) * linkage.period
    offset = max(1e-12 * linkage.min_clearance, 8 * np.finfo(float).eps * linkage.length_scale)
    return _solve(model.rhs, model.event, RecordKernels(model).on_event, _monitored(model),
                  y0, p, edges, model.N_EVENTS, offset, method, rtol, atol)


def _solve(rhs, event, on_event, monitored, y0, p, edges, n_events, offset, method, rtol,
           atol) -> ScipyResult:
    """solve_ivp with one terminal event per switching function (offset by `offset`: see
    solve_scipy), restarted after each event with the memory switched by on_event;
    max of monitored(t, y, p) per window, refined on the dense output."""
    edges = np.asarray(edges, dtype=float)
    y = np.ascontiguousarray(y0, dtype=float)
    p = p.copy()
    t = float(edges[0])
    t_end = float(edges[-1])
    segments = []
    event_times = []
    nfev = 0
    n = len(y)

    def fun(tt, yy):
        res = np.empty(n)
        rhs(tt, np.ascontiguousarray(yy), p, res)
        return res

    def make_event(j):
        def ev(tt, yy):
            return event(tt, np.ascontiguousarray(yy), p, j)[0] - offset
        ev.terminal = True
        ev.direction = 1
        return ev

    events = [make_event(j) for j in range(n_events)]
    step_points = []
    while t < t_end:
        # the implicit methods estimate their Jacobian by finite differences whose probe
        # factors overflow on the stiff contact, and a long trial step of the explicit ones
        # can go far through the wall, where the Hertz force overflows (inf - inf in scipy's
        # error estimate): scipy rejects such steps, the warnings come from inside it and
        # the results are checked against the reference either way
        with np.errstate(over="ignore", invalid="ignore"):
            sol = solve_ivp(fun, (t, t_end), y, method=method, rtol=rtol, atol=atol,
                            events=events, dense_output=True)
        if not sol.success:
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        nfev += sol.nfev
        p_seg = p.copy()
        hit = [j for j in range(n_events) if len(sol.t_events[j])]
        if sol.status == 1 and hit:
            first = min(hit, key=lambda j: sol.t_events[j][0])
            t_new = float(sol.t_events[first][0])
            y = np.ascontiguousarray(sol.y_events[first][0])
        else:
            first = -1
            t_new = t_end
            y = np.ascontiguousarray(sol.y[:, -1])
        segments.append((t, t_new, sol.sol, p_seg))
        for tt, yy in zip(sol.t, sol.y.T):
            if tt <= t_new:
                step_points.append((tt, monitored(tt, np.ascontiguousarray(yy), p_seg)))
        if t_new >= t_end:
            break
        event_times.append(t_new)
        t = t_new
        on_event(t, y, p, first)

    res = ScipyResult(edges, np.zeros(len(edges) - 1), np.zeros(len(edges) - 1),
                      np.asarray(event_times), nfev, segments)
    res.monitored = monitored
    pts = np.array(step_points)
    for w in range(len(edges) - 1):
        a, b = edges[w], edges[w + 1]
        inside = pts[(pts[:, 0] >= a) & (pts[:, 0] <= b)]
        cand = [(a, _mag(res, a)), (b, _mag(res, b))] + [tuple(r) for r in inside]
        cand.sort()
        times = np.array([c[0] for c in cand])
        vals = np.array([c[1] for c in cand])
        best_v, best_t = float(np.max(vals)), float(times[int(np.argmax(vals))])
        # refine around the highest few local maxima of the samples (the highest sample may
        # sit on a lower crest than the true maximum: as the compiled integrator, N_CRESTS)
        is_max = np.r_[True, vals[1:] >= vals[:-1]] & np.r_[vals[:-1] >= vals[1:], True]
        crests = np.flatnonzero(is_max)
        for i in crests[np.argsort(-vals[crests])][:N_CRESTS]:
            for lo, hi in ((times[max(i - 1, 0)], times[i]),
                           (times[i], times[min(i + 1, len(times) - 1)])):
                if hi <= lo:
                    continue
                # refine inside one segment only (the memory is constant there)
                for t0, t1, _, _ in segments:
                    lo2, hi2 = max(lo, t0), min(hi, t1)
                    if hi2 > lo2:
                        r = minimize_scalar(lambda tt: -_mag(res, tt), bounds=(lo2, hi2),
                                            method="bounded",
                                            options={"xatol": 1e-15 + 1e-13 * (hi2 - lo2)})
                        if -r.fun > best_v:
                            best_v, best_t = -r.fun, r.x
        res.peaks[w] = best_v
        res.peak_times[w] = best_t
    return res


def _mag(res: ScipyResult, t: float) -> float:
    y, p = res.state(t)
    return res.monitored(t, np.ascontiguousarray(y), p)
