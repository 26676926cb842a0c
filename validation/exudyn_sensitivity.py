"""Finite-difference sensitivities through Exudyn against the reduced model's DDM.

For a named case and parameters (dotted `Linkage` names): central differences of Exudyn
runs (fixed step h, the parameter moved by `linkage_ddm.fd_step`: +-rel b0 for the
masses, inertias and gravity) of the monitored force's magnitude |F|(t) and of its RMS
over the last revolution, against DDM on the generated model's exact Jacobians
(`sensitivities(linkage, names, method="ddm")`, rtol 1e-10) on Exudyn's own grid thinned
to `SAMPLES_PER_REVOLUTION` points. Two measures per parameter:

- ``series``: relative RMS difference of d|F|/db over the revolution (a derivative
  magnifies Exudyn's phase error at the contact frequency, so this converges at the
  step's second order, slowly in absolute terms);
- ``rms``: relative difference of d RMS(|F|)/db (an integral over the revolution: no phase
  error, it shows the FD step's truncation and Exudyn's own error).

    python -m validation.exudyn_sensitivity paper_slider_crank [--steps 4e-6 2e-6]
        [--parameters coupler.mass slider.mass ...] [--rel 1e-3] [--revolutions 2]
        [--ddm-rtol 1e-10] [--settled N]

``--settled N`` starts every run (Exudyn's and the DDM's) from the reduced model's state
after N revolutions (`linkage_model.settled_start`, at the DDM's rtol), held fixed: the
sensitivities of the periodic response, without the start's settling impacts (the
four-bar: docs/exudyn.md).
"""

from __future__ import annotations

import argparse

import numpy as np

#: per case: the three parameters of the docs' table (masses and an inertia, or gravity,
#: that move the monitored force; the driven crank's inertia does not: its speed is
#: prescribed)
PARAMETERS = {
    "paper_slider_crank": ("coupler.mass", "slider.mass", "coupler.inertia"),
    "slider_crank_two_clearances": ("coupler.mass", "slider.mass", "coupler.inertia"),
    # (from a settled start, docs/exudyn.md: d RMS/d rocker.inertia is 1e-4 of the masses'
    # at 10 rpm, below what Exudyn's differences resolve; gravity loads every joint)
    "four_bar": ("coupler.mass", "rocker.mass", "gravity"),
}

#: DDM / FD comparison points per revolution
SAMPLES_PER_REVOLUTION = 3000


def _magnitude(tr) -> np.ndarray:
    return np.hypot(tr.base_force[:, 0], tr.base_force[:, 1])


def _rms(t, y) -> float:
    return float(np.sqrt(np.trapezoid(y * y, t) / (t[-1] - t[0])))


def exudyn_fd(linkage, names, revolutions: int, step: float, rel: float, start=None):
    """(t of the last revolution, d|F|/db (n, p), d RMS/db (p,)) by central differences
    (`linkage_ddm.central_differences`, steps `fd_step`: rel b0 for the masses, inertias
    and gravity) of Exudyn runs at fixed step `step` (from `start`)."""
    from mbs_clearance.solve.linkage_ddm import central_differences

    steps, plus, minus = central_differences(linkage, names, rel, _exudyn_last_revolution,
                                             (revolutions, step, start))
    # one grid for every parameter: Exudyn's grids may differ by a few steps (the
    # four-bar's 2nd revolution: 385184 and 385189 samples; its adaptiveStep, on by
    # default, cuts a step whose Newton iteration fails)
    t_out = plus[0][0]
    series = [(np.interp(t_out, p[0], p[1]) - np.interp(t_out, m[0], m[1])) / (2 * d)
              for p, m, d in zip(plus, minus, steps)]
    rms = [(p[2] - m[2]) / (2 * d) for p, m, d in zip(plus, minus, steps)]
    return t_out, np.column_stack(series), np.array(rms)


def _exudyn_last_revolution(job):
    """(t, |F|, its RMS) over the last revolution of an Exudyn run of the design."""
    from mbs_clearance import simulate

    design, revolutions, step, start = job
    tr = simulate(design, revolutions, backend="exudyn", step_size=step, start=start)
    m = tr.revolution_mask(revolutions)
    t, f = tr.t[m], _magnitude(tr)[m]
    return t, f, _rms(t, f)


def _reduced_window_rms(job):
    """The RMS of |F| over the window (lo, hi) of a reduced run's own steps."""
    from mbs_clearance import simulate

    design, revolutions, rtol, start, lo, hi = job
    tr = simulate(design, revolutions, rtol=rtol, start=start)
    return _rms(*_on_window(tr.t, lo, hi, _magnitude(tr)))


def ddm(linkage, names, revolutions: int, t: np.ndarray, rtol: float = 1e-10, start=None,
        method: str = "ddm", rel: float | None = None, window=None):
    """(d|F|/db (n, p) at times t, d RMS/db (p,)) by DDM (rtol 1e-10 unless given; or, with
    method "fd", by central differences of reduced runs at relative step `rel`). The RMS
    (over `window`, default t[0]..t[-1]) and its derivative come from the runs' own steps,
    not from the samples t."""
    lo, hi = (t[0], t[-1]) if window is None else window
    from mbs_clearance.analysis.sensitivity import sensitivities

    extra = {} if rel is None else {"fd_relative_step": rel}
    # (the paper's field names take no start: pass one only when given)
    begin = {} if start is None else {"start": start}
    s = sensitivities(linkage, list(names), revolutions=revolutions, method=method, t_eval=t,
                      rtol=rtol, **begin, **extra)
    d = s.base_force_magnitude
    if method == "ddm":
        # d RMS/db over the DDM's own steps (error-controlled through the contacts), not
        # over the comparison grid t: a trapezoid over its samples of the contacts' spikes
        # depends on where they fall (the four-bar: 1e-3 between two Exudyn grids)
        full = sensitivities(linkage, list(names), revolutions=revolutions, rtol=rtol,
                             **begin)
        return d, _rms_derivative(*_on_window(full.t, lo, hi, _magnitude(full.trajectory),
                                              full.base_force_magnitude))
    # method "fd": d RMS/db by central differences of the RMS over each run's own steps
    from mbs_clearance.solve.linkage_ddm import central_differences

    steps, plus, minus = central_differences(linkage, names, rel, _reduced_window_rms,
                                             (revolutions, rtol, start, lo, hi))
    return d, (np.array(plus) - np.array(minus)) / (2 * steps)


def _on_window(t, lo, hi, *series):
    """(t, *series) of a run's steps strictly inside (lo, hi) with the series (n,) or
    (n, p) interpolated at lo and hi: a window whose ends are not steps of the run
    (Exudyn's grid ends at the revolution's edges to round-off, where an adaptive run's
    nearest step can be microseconds away: 1e-2 of d RMS/db in the two-joint case)."""
    inner = (t > lo) & (t < hi)

    def ends(y):
        cols = y.reshape(len(t), -1)
        rows = [[np.interp(x, t, c) for c in cols.T] for x in (lo, hi)]
        return np.vstack([rows[0], cols[inner], rows[1]]).reshape((-1, *y.shape[1:]))

    return (np.concatenate([[lo], t[inner], [hi]]), *(ends(y) for y in series))


def _rms_derivative(t, f, d) -> np.ndarray:
    """d RMS(f)/db from f(t) and its derivatives d (n, p): (1 / (T RMS)) int f d dt."""
    r = _rms(t, f)
    return np.array([np.trapezoid(f * d[:, k], t) / ((t[-1] - t[0]) * r)
                     for k in range(d.shape[1])])


def compare_fd_ddm(name: str, steps, names=None, revolutions: int = 2, rel: float = 1e-3,
                   ddm_rtol: float = 1e-10, settled: int = 0):
    """Rows (step, parameter, series difference, rms difference) for case `name` (from the
    state after `settled` revolutions if > 0). A step of 0 is the reduced model's central
    differences (rtol 1e-11) on the DDM's grid: the finite-difference step's own error."""
    from mbs_clearance.model import cases
    from mbs_clearance.solve.linkage_model import settled_start

    linkage = cases.CASES[name]()
    names = tuple(names or PARAMETERS[name])
    start = settled_start(linkage, settled, rtol=ddm_rtol) if settled else None
    rows = []
    for step in steps:
        if step == 0.0:
            # the last revolution, as the Exudyn rows
            ts = np.linspace((revolutions - 1) * linkage.period, revolutions * linkage.period,
                             SAMPLES_PER_REVOLUTION + 1)
            ref0 = (ts, *ddm(linkage, names, revolutions, ts, ddm_rtol, start))
            fd_series, fd_rms = ddm(linkage, names, revolutions, ts, 1e-11, start, "fd", rel)
            rows += _rows(step, names, ref0, fd_series, fd_rms, 1)
            continue
        t, fd_series, fd_rms = exudyn_fd(linkage, names, revolutions, step, rel, start)
        stride = max(1, len(t) // SAMPLES_PER_REVOLUTION)
        ts = t[::stride]
        # (the RMS over the Exudyn runs' window, which the thinned grid may end short of)
        reference = (ts, *ddm(linkage, names, revolutions, ts, ddm_rtol, start,
                              window=(t[0], t[-1])))
        rows += _rows(step, names, reference, fd_series, fd_rms, stride)
    return rows


def _rows(step, names, reference, fd_series, fd_rms, stride):
    _, d_series, d_rms = reference
    rows = []
    for k, p in enumerate(names):
        a = d_series[:, k]
        b = fd_series[::stride, k]
        rows.append(dict(step=step, parameter=p,
                         series=float(np.sqrt(np.mean((a - b) ** 2) / np.mean(a * a))),
                         rms=float(abs(fd_rms[k] / d_rms[k] - 1.0)),
                         ddm_rms=float(d_rms[k]), fd_rms=float(fd_rms[k])))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case")
    ap.add_argument("--steps", type=float, nargs="+", default=[4e-6, 2e-6])
    ap.add_argument("--parameters", nargs="+")
    ap.add_argument("--rel", type=float, default=1e-3)
    ap.add_argument("--revolutions", type=int, default=2)
    ap.add_argument("--ddm-rtol", type=float, default=1e-10,
                    help="rtol of the DDM reference (default 1e-10)")
    ap.add_argument("--settled", type=int, default=0, metavar="N",
                    help="start every run from the state after N revolutions (0: centred)")
    args = ap.parse_args(argv)
    rows = compare_fd_ddm(args.case, args.steps, args.parameters, args.revolutions, args.rel,
                          args.ddm_rtol, args.settled)
    print("| step (us) | parameter | d RMS/db DDM | rel. diff. d RMS/db | rel. RMS diff. "
          "d|F|/db |")
    print("|---|---|---|---|---|")
    for r in rows:
        step = "reduced FD" if r["step"] == 0.0 else f"{r['step'] * 1e6:g}"
        print(f"| {step} | {r['parameter']} | {r['ddm_rms']:.4g} | "
              f"{r['rms']:.1e} | {r['series']:.1e} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
