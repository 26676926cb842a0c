"""The reduced model's equations integrated by `scipy.integrate.solve_ivp`, with events.

An independent integrator for the same equations: scipy steps, locates the contact onset and
separation with its own event machinery (terminal events, restart with the memory updated),
and the peaks of |F12| are refined on scipy's dense output. Shares only the right-hand side
and the contact-mode update with the compiled integrator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from mbs_clearance import reduced
from mbs_clearance.mechanism import SliderCrank

__all__ = ["ScipyResult", "solve_scipy"]


@dataclass
class ScipyResult:
    """Peaks per window, segments between events and solver counts."""

    edges: np.ndarray
    peaks: np.ndarray
    peak_times: np.ndarray
    event_times: np.ndarray
    nfev: int
    segments: list  # (t_start, t_end, OdeSolution, p snapshot)

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """State and parameter vector (memory) at time t from the dense output."""
        for t0, t1, sol, p in self.segments:
            if t0 <= t <= t1:
                return sol(t), p
        raise ValueError(f"t = {t} outside the solution")


def solve_scipy(mech: SliderCrank, edges: np.ndarray | None = None, revolutions: int = 4,
                method: str = "DOP853", rtol: float = 1e-12,
                atol: np.ndarray | None = None) -> ScipyResult:
    """Integrate with solve_ivp from edges[0] to edges[-1]; max |F12| per window."""
    if edges is None:
        edges = reduced.window_edges(mech, revolutions)
    edges = np.asarray(edges, dtype=float)
    atol = reduced.default_atol(mech, rtol) if atol is None else atol
    p = reduced.pack_parameters(mech)
    y = reduced.initial_state(mech)
    t = float(edges[0])
    t_end = float(edges[-1])
    segments = []
    event_times = []
    nfev = 0
    buf = np.empty(reduced.N_STATE)

    def fun(tt, yy):
        out = np.empty(reduced.N_STATE)
        reduced.rhs(tt, np.ascontiguousarray(yy), p, out)
        return out

    # the switching function is offset by the round-off of the penetration (a difference of
    # coordinates of size L2 + L3): a state located on the surface may come out a few ulps
    # on the far side in the new mode, and scipy, which looks only for sign changes between
    # step ends, would then miss a crossing in the first step after the restart (seen after
    # a separation: the journal flew through the wall)
    offset = max(1e-12 * mech.clearance,
                 8 * np.finfo(float).eps * (mech.crank_length + mech.coupler_length))

    def ev(tt, yy):
        return reduced.event(tt, np.ascontiguousarray(yy), p, 0)[0] - offset

    ev.terminal = True
    ev.direction = 1
    step_points = []
    while t < t_end:
        # the implicit methods estimate their Jacobian by finite differences whose probe
        # factors overflow on the stiff contact, and a long trial step of the explicit ones
        # can go far through the wall, where the Hertz force overflows (inf - inf in scipy's
        # error estimate): scipy rejects such steps, the warnings come from inside it and
        # the results are checked against the reference either way
        with np.errstate(over="ignore", invalid="ignore"):
            sol = solve_ivp(fun, (t, t_end), y, method=method, rtol=rtol, atol=atol,
                            events=ev, dense_output=True)
        if not sol.success:
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        nfev += sol.nfev
        p_seg = p.copy()
        if sol.status == 1 and len(sol.t_events[0]):
            t_new = float(sol.t_events[0][0])
            y = np.ascontiguousarray(sol.y_events[0][0])
        else:
            t_new = t_end
            y = np.ascontiguousarray(sol.y[:, -1])
        segments.append((t, t_new, sol.sol, p_seg))
        for tt, yy in zip(sol.t, sol.y.T):
            if tt <= t_new:
                step_points.append((tt, reduced.monitor(tt, np.ascontiguousarray(yy), p_seg)))
        if t_new >= t_end:
            break
        event_times.append(t_new)
        t = t_new
        reduced.on_event(t, y, p, 0)
        buf[:] = y

    res = ScipyResult(edges, np.zeros(len(edges) - 1), np.zeros(len(edges) - 1),
                      np.asarray(event_times), nfev, segments)
    pts = np.array(step_points)
    for w in range(len(edges) - 1):
        a, b = edges[w], edges[w + 1]
        inside = pts[(pts[:, 0] >= a) & (pts[:, 0] <= b)]
        cand = [(a, _mag(res, a)), (b, _mag(res, b))] + [tuple(r) for r in inside]
        cand.sort()
        times = np.array([c[0] for c in cand])
        vals = np.array([c[1] for c in cand])
        i = int(np.argmax(vals))
        best_v, best_t = vals[i], times[i]
        for lo, hi in ((times[max(i - 1, 0)], times[i]), (times[i], times[min(i + 1,
                                                                             len(times) - 1)])):
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
    return reduced.monitor(t, np.ascontiguousarray(y), p)
