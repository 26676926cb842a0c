"""What limits a case's step size: the accuracy of its motion or a fast contact vibration.

For one named case (default: the four-bar), 4 drive revolutions from the centred start:

- our integrator at several tolerances (dopri5 and DOP853): function evaluations, accepted
  and rejected steps, and the relative error of the 4th revolution's refined peak against
  rtol 1e-12. Where the evaluations hardly fall as rtol is loosened, something other than
  the tolerance sets the step;
- along the default run, at `--states` recorded states: the eigenvalue of largest modulus
  of the state Jacobian d(qdot, qddot)/d(q, qdot) in the state's contact mode (central
  differences of the compiled right-hand side, independent of the generated Jacobians), its
  real and imaginary parts, and h |lambda| with h the accepted step there. An eigenvalue
  near the imaginary axis is a lightly damped vibration (in contact: the journal on the
  contact stiffness); h |lambda| of order one means the steps resolve that vibration with a
  few steps per period, 2 pi / (h |lambda|). Beside it the method's stability bound along
  that eigenvalue's direction in the complex plane (`stability_radius`: the largest r with
  |R(r e^(i phi))| <= 1 for the method's stability function R(z) = 1 + z b^T (I - z A)^-1 1):
  steps at that bound are set by stability, not by the tolerance, and an implicit method
  that damps the vibration changes the forces it carries;
- the cost of the model's own calls in an event-exact step: one call of `rhs`, `monitor`
  (with the outputs) and `event` each, in compiled loops over the default run's recorded
  states (medians of 5), and the calls per accepted and per attempted step, as ns per
  function evaluation (nfev) beside the default peak-only run's time per evaluation (median
  of 3 runs): what is left of the run for the integrator's own work;
- with ``--scipy-implicit``: scipy's Radau (implicit, L-stable; its Jacobian by finite
  differences) on the same compiled model at rtol 1e-6 and 1e-7
  (`validation.scipy_reference.solve_scipy_linkage`): whether an implicit method takes
  longer steps at a useful error (about 40 s per row for the four-bar).

    python -m benchmarks.step_limit [--case four_bar] [--states 400] [--scipy-implicit]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mbs_clearance import peak_base_force
from mbs_clearance.cli import int_at_least
from mbs_clearance.model.cases import CASES
from mbs_clearance.solve.linkage_model import run
from validation.timing import machine_summary, timed

REVOLUTION = 4
SETTINGS = (("dopri5", 1e-5), ("dopri5", 1e-6), ("dopri5", 1e-7), ("dopri5", 1e-8),
            ("dop853", 1e-5), ("dop853", 3e-6), ("dop853", 1e-6), ("dop853", 1e-7))


def state_jacobian(model, t, y, p, rel=1e-7) -> np.ndarray:
    """d(qdot, qddot)/d(q, qdot) at (t, y) with the memory in p, by central differences of
    `model.rhs` (step rel |y_k|, at least rel 1e-3)."""
    n = 2 * model.N_Q
    fp = np.empty(model.N_STATE)
    fm = np.empty(model.N_STATE)
    jac = np.empty((n, n))
    for c in range(n):
        d = rel * max(abs(y[c]), 1e-3)
        yp = y.copy()
        yp[c] += d
        ym = y.copy()
        ym[c] -= d
        model.rhs(t, yp, p, fp)
        model.rhs(t, ym, p, fm)
        jac[:, c] = (fp[:n] - fm[:n]) / (2.0 * d)
    return jac


def stability_radius(method: str, angle: float, r_max: float = 20.0) -> float:
    """The largest r such that the explicit RK `method` (a name of integrator.METHODS) is
    stable, |R(r e^(i angle))| <= 1, for every radius up to r along the direction `angle`
    (pi / 2: the imaginary axis; larger: damped), R(z) = 1 + z b^T (I - z A)^-1 1 its
    stability function; scanned in steps of 1e-3 and refined by bisection."""
    from mbs_clearance.numerics.integrator import METHODS

    tab = METHODS[method]
    s = tab.B.shape[0]
    a = tab.A[:s, :s]
    ones = np.ones(s)
    direction = np.exp(1j * angle)

    def unstable(r):
        z = r * direction
        return abs(1.0 + z * tab.B @ np.linalg.solve(np.eye(s) - z * a, ones)) > 1.0 + 1e-12

    lo = 0.0
    for r in np.arange(1e-3, r_max, 1e-3):
        if unstable(r):
            hi = r
            break
        lo = r
    else:
        return r_max
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if unstable(mid) else (mid, hi)
    return lo


def model_call_cost(linkage, default=None) -> dict:
    """ns per call of the default model's rhs, monitor (with outputs) and event (joint 0)
    over the default run's recorded states (`default`: that run's result, if at hand); the
    run's counts; the model's calls per evaluation (per attempted step: s - 1 rhs, the
    monitor and the embedded solution's event per joint; per accepted step: the event
    search's interior sample per joint) and the default peak-only run's time per evaluation
    (median of 3)."""
    from mbs_clearance.numerics.integrator import METHODS

    from .case_speed import model_kernel_ns

    model, ts, ys, ms, _, _, stats, _, p = run(linkage, REVOLUTION) if default is None else default
    cost = model_kernel_ns(model, ts, ys, ms, p)
    rhs, mon, ev = cost["rhs"], cost["monitor"], cost["event"]
    stages = METHODS["dopri5"].B.shape[0]
    attempts = stats["naccept"] + stats["nreject"]
    J = model.N_EVENTS
    model_ns = (attempts * ((stages - 1) * rhs + mon + J * ev) + stats["naccept"] * J * ev)
    run_s = timed(lambda: run(linkage, REVOLUTION, record=False), 3)[0]
    return {"rhs_ns": rhs, "monitor_ns": mon, "event_ns": ev, "nfev": stats["nfev"],
            "naccept": stats["naccept"], "nreject": stats["nreject"],
            "model_ns_per_nfev": model_ns / stats["nfev"],
            "run_ns_per_nfev": 1e9 * run_s / stats["nfev"]}


def spectrum_along_run(linkage, states: int, default=None) -> dict:
    """The dominant eigenvalue and h |lambda| at `states` recorded states of the default run
    (`default`: that run's result, if at hand)."""
    model, ts, ys, ms, *_, p = run(linkage, REVOLUTION) if default is None else default
    h = np.diff(ts)
    q = p.copy()
    rows = np.unique(np.linspace(1, len(ts) - 2, states).astype(int))
    lam = np.empty(len(rows), dtype=complex)
    for k, i in enumerate(rows):
        q[model.MEM_START:model.MEM_START + model.N_MEM] = ms[i]
        ev = np.linalg.eigvals(state_jacobian(model, ts[i], ys[i].copy(), q))
        lam[k] = ev[np.argmax(np.abs(ev))]
    hl = h[rows] * np.abs(lam)
    return {"states": len(rows), "contact_fraction": float(np.mean(ms[rows, 0] > 0.5)),
            "re_median": float(np.median(lam.real)),
            "im_median": float(np.median(np.abs(lam.imag))),
            "angle_median": float(np.median(np.angle(lam.real + 1j * np.abs(lam.imag)))),
            "h_lambda": [float(x) for x in np.quantile(hl, [0.1, 0.5, 0.9])],
            "steps": len(ts) - 1, "duration": float(ts[-1])}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=sorted(CASES), default="four_bar")
    ap.add_argument("--states", type=int_at_least(1), default=400,
                    help="states sampled for the spectrum")
    ap.add_argument("--scipy-implicit", action="store_true",
                    help="also scipy's Radau at rtol 1e-6 and 1e-7 (slow)")
    args = ap.parse_args(argv)
    lk = CASES[args.case]()
    ref = peak_base_force(lk, REVOLUTION, rtol=1e-12)
    print(f"{args.case}: rev-{REVOLUTION} peak at rtol 1e-12: {ref:.10g} N\n")
    print("| method | rtol | nfev | accepted | rejected | peak error |")
    print("|---|---|---|---|---|---|")
    for method, rtol in SETTINGS:
        _, _, _, _, peaks, _, stats, _, _ = run(lk, REVOLUTION, method=method, rtol=rtol,
                                                record=False)
        err = abs(peaks[REVOLUTION - 1] / ref - 1.0)
        print(f"| {method} | {rtol:g} | {stats['nfev']} | {stats['naccept']} | "
              f"{stats['nreject']} | {err:.1e} |")
    if args.scipy_implicit:
        from validation.scipy_reference import solve_scipy_linkage

        for rtol in (1e-6, 1e-7):
            t0 = time.perf_counter()
            res = solve_scipy_linkage(lk, REVOLUTION, method="Radau", rtol=rtol)
            err = abs(res.peaks[REVOLUTION - 1] / ref - 1.0)
            print(f"| scipy Radau | {rtol:g} | {res.nfev} | | | {err:.1e} "
                  f"({len(res.event_times)} events, {time.perf_counter() - t0:.0f} s) |")
    default = run(lk, REVOLUTION)
    s = spectrum_along_run(lk, args.states, default)
    q10, q50, q90 = s["h_lambda"]
    print(f"\ndefault run: {s['steps']} steps over {s['duration']:.4g} s; at {s['states']} "
          f"of its states ({100 * s['contact_fraction']:.1f} % in contact) the dominant "
          f"eigenvalue is {s['re_median']:.4g} +/- {s['im_median']:.4g} i 1/s (medians), "
          f"h |lambda| = {q10:.2f} / {q50:.2f} / {q90:.2f} (10 / 50 / 90 %): "
          f"{2 * np.pi / q50:.1f} steps per period of the vibration at "
          f"{s['im_median'] / (2e3 * np.pi):.3g} kHz, "
          f"{s['duration'] * s['im_median'] / (2 * np.pi):.3g} periods in the run")
    zeta = -np.cos(s["angle_median"])
    print(f"damping ratio {zeta:.3g}; stability bound of h |lambda| along that direction: "
          + ", ".join(f"{m} {stability_radius(m, s['angle_median']):.2f}"
                      for m in ("dopri5", "dop853")))
    c = model_call_cost(lk, default)
    print(f"\nthe model's calls (default run, dopri5 at rtol 1e-7): rhs {c['rhs_ns']:.0f} ns, "
          f"monitor {c['monitor_ns']:.0f} ns, event {c['event_ns']:.0f} ns per call; "
          f"{c['nfev']} evaluations in {c['naccept']} + {c['nreject']} steps: the model's "
          f"calls {c['model_ns_per_nfev']:.0f} ns per evaluation, the peak-only run "
          f"{c['run_ns_per_nfev']:.0f} ns per evaluation")
    print("\n" + machine_summary())


if __name__ == "__main__":
    main()
