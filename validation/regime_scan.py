"""Peak per revolution of a named case by a fixed-step RK4 on its compiled kernels.

    python -m validation.regime_scan four_bar 8 600000 crank_speed=1.0471975511965976

Arguments: case name, revolutions, steps per revolution, then overrides NAME=VALUE of the
case. Prints the peak of the monitored force in each revolution (sampled at the steps, not
refined) and the number of contact events. An exploration tool for choosing a case's
operating point (is it periodic?), independent of the adaptive integrator: a contact onset
or separation is located by bisection of the step, then the joint's mode is switched by the
generated on_event. The step must resolve the contact oscillation (h omega_contact < 1):
check a result by halving the step.

    python -m validation.regime_scan four_bar 8 adaptive 1e-10,1e-11 clearance=1e-5

With "adaptive" and a list of rtol in place of the steps: the same case through the
adaptive integrator (`simulate`'s peak-only run) at each rtol: the refined peak of every
revolution, the contact events in total and in the first revolution, and the largest
relative difference of the peaks between the rtols from each revolution on (the
periodicity check of docs/cases.md: a periodic regime's peaks agree between rtols and
repeat from revolution to revolution; a chaotic one's differ between rtols). A crank speed
may be given in rpm (``crank_speed=20rpm``).

    python -m validation.regime_scan four_bar 200 adaptive 1e-9,1e-10 --from 150
    python -m validation.regime_scan four_bar 8 adaptive 1e-9 crank_speed=20rpm --events

Then a summary of revolutions K to the last (``--from K``, default 2): the peaks' median
and range at the tightest rtol, the range and median of their change between consecutive
revolutions of that span (from revolution K + 1 on), and of their difference between the
rtols. ``--events``: the contact events of each revolution at each rtol, counted from a
recording run (the same steps; it holds every step in memory, so for short runs), and
their range and sum over the summary's revolutions.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from mbs_clearance.generate import load_model
from mbs_clearance.model import cases
from mbs_clearance.solve.linkage_model import initial_state, pack_parameters


def make_runner(model):
    """A fixed-step RK4 with event bisection on the compiled model's kernels (its record's
    rhs, event, on_event and monitor, called from Python: a slow loop, a few microseconds
    per call)."""
    rec, ffi = model.record, model.ffi
    J, n_out = model.N_EVENTS, model.N_OUT

    def ptr(a):
        return ffi.cast("double *", ffi.from_buffer(a))

    def rhs(t, y, p, dydt):
        rec.rhs(t, ptr(y), y.shape[0], ptr(p), ptr(dydt))

    g_gd = np.empty(2)

    def event(t, y, p, j):
        rec.event(t, ptr(y), ptr(p), j, ptr(g_gd))
        return g_gd[0]

    def step(t, y, h, p, k1, k2, k3, k4):
        rhs(t, y, p, k1)
        rhs(t + 0.5 * h, y + 0.5 * h * k1, p, k2)
        rhs(t + 0.5 * h, y + 0.5 * h * k2, p, k3)
        rhs(t + h, y + h * k3, p, k4)
        return y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    def run(y0, p, h, period, n_rev):
        n = y0.shape[0]
        k1, k2, k3, k4 = (np.empty(n) for _ in range(4))
        out, g, gd, dy = np.empty(max(n_out, 1)), np.empty(J), np.empty(J), np.empty(n)
        peaks = np.zeros(n_rev)
        events = np.zeros(n_rev, dtype=np.int64)
        t_end = n_rev * period
        t, y = 0.0, np.array(y0, dtype=float)
        g_old = np.array([event(t, y, p, j) for j in range(J)])
        while t < t_end * (1.0 - 1e-14):
            hh = min(h, t_end - t)
            y_new = step(t, y, hh, p, k1, k2, k3, k4)
            hit = -1
            for j in range(J):
                if g_old[j] != 0.0 and (g_old[j] < 0.0) != (event(t + hh, y_new, p, j) < 0.0):
                    hit = j
            if hit >= 0:              # land on the crossing: bisection of the step
                lo, hi = 0.0, hh
                for _ in range(60):
                    mid = 0.5 * (lo + hi)
                    y_mid = step(t, y, mid, p, k1, k2, k3, k4)
                    if (event(t + mid, y_mid, p, hit) < 0.0) == (g_old[hit] < 0.0):
                        lo = mid
                    else:
                        hi = mid
                hh = hi
                y_new = step(t, y, hh, p, k1, k2, k3, k4)
                rec.on_event(t + hh, ptr(y_new), ptr(p), hit)
                events[min(int((t + hh) / period), n_rev - 1)] += 1
            t += hh
            y = y_new
            for j in range(J):
                g_old[j] = event(t, y, p, j)
            value = rec.monitor(t, ptr(y), n, ptr(p), ptr(dy), ptr(out), n_out, ptr(g), ptr(gd))
            k = min(int(t / period), n_rev - 1)
            peaks[k] = max(peaks[k], value)
        return peaks, events

    return run


#: step attempts allowed to an adaptive run (the four-bar's sliding mode at rtol 1e-11 takes
#: about a million steps per revolution; its 200 revolutions at rtol 1e-10, about 90 million
#: steps, are estimated before the run at 1.1e8 from the first revolution's impacts)
MAX_STEPS = 1_000_000_000


def adaptive_peaks(linkage, revolutions: int, rtol: float, per_revolution: bool = False
                   ) -> dict:
    """Peaks per revolution (refined, N) and contact events (total, first revolution) of
    `linkage` through the adaptive integrator at `rtol`, recording nothing; with
    `per_revolution` the run records its steps (the same steps) and `per_revolution`
    holds the contact events of each revolution: the steps where a joint's mode switches."""
    from mbs_clearance.solve.linkage_model import run

    first = run(linkage, 1, rtol=rtol, record=False, max_steps=MAX_STEPS).stats["nevent"]
    out = run(linkage, revolutions, rtol=rtol, record=per_revolution, max_steps=MAX_STEPS)
    res = {"rtol": rtol, "peaks": np.asarray(out.peaks), "events": out.stats["nevent"],
           "events_first": first, "nfev": out.stats["nfev"]}
    if per_revolution:
        res["per_revolution"] = switches_per_revolution(out.ts, out.ms, linkage.period,
                                                        revolutions)
    return res


def switches_per_revolution(ts, ms, period: float, revolutions: int) -> np.ndarray:
    """Contact switches per revolution of a recorded run: the steps (times `ts`, s) where a
    joint's mode (the even columns of the memories `ms`) differs from the step before,
    counted in the revolution (`period`, s) that holds the step."""
    modes = np.asarray(ms)[:, 0::2]
    switched = np.any(np.diff(modes, axis=0) != 0, axis=1)
    rev = np.minimum((np.asarray(ts)[1:][switched] / period).astype(int), revolutions - 1)
    return np.bincount(rev, minlength=revolutions)


def settled_summary(runs: list[dict], first: int) -> dict:
    """From `adaptive_peaks` of one case at several rtols and their `periodicity`: over
    revolutions `first` to the last (1-based), the peaks at the tightest rtol (median, min,
    max, N), their relative change between consecutive revolutions of that span (from
    revolution `first` to `first` + 1 on) and their difference between the rtols (min,
    median, max; None for one rtol), and each rtol's contact events per revolution (min,
    max, and their sum over the span; where counted)."""
    per = periodicity(runs)
    k = slice(first - 1, None)
    tight = runs[int(np.argmin([r["rtol"] for r in runs]))]["peaks"][k]

    def spread(x):
        return float(np.min(x)), float(np.median(x)), float(np.max(x))

    return {"peak": (float(np.median(tight)), float(tight.min()), float(tight.max())),
            "change": spread(per["rev_to_rev"][first:]),
            "between": spread(per["between_rtols"][k]) if len(runs) > 1 else None,
            "events": [(int(r["per_revolution"][k].min()), int(r["per_revolution"][k].max()),
                        int(r["per_revolution"][k].sum()))
                       if "per_revolution" in r else None for r in runs]}


def periodicity(runs: list[dict]) -> dict:
    """From `adaptive_peaks` of one case at several rtols: per revolution k, the largest
    relative difference of the peaks between the rtols (`between_rtols`) and, at the
    tightest rtol, the relative change from revolution k - 1 (`rev_to_rev`, NaN for k =
    1); the events after the first revolution at each rtol (`later_events`)."""
    peaks = np.array([r["peaks"] for r in runs])
    tight = peaks[int(np.argmin([r["rtol"] for r in runs]))]
    between = (peaks.max(axis=0) - peaks.min(axis=0)) / np.abs(tight)
    rev = np.concatenate([[np.nan], np.abs(np.diff(tight)) / np.abs(tight[1:])])
    return {"between_rtols": between, "rev_to_rev": rev,
            "later_events": [r["events"] - r["events_first"] for r in runs]}


def main_adaptive(name: str, revolutions: int, rtols: list[float], overrides: dict,
                  first: int = 2, events: bool = False, linkage=None) -> None:
    """Print `adaptive_peaks` at each rtol, their `periodicity` and the `settled_summary`
    from revolution `first` (the command line); `linkage`: the case with `overrides`,
    where the caller has built it."""
    linkage = linkage or cases.CASES[name](**overrides)
    runs = []
    for rtol in rtols:
        t0 = time.perf_counter()
        r = adaptive_peaks(linkage, revolutions, rtol, per_revolution=events)
        runs.append(r)
        print(f"{name} {overrides} rtol {rtol:g}: nfev {r['nfev']}, contact events "
              f"{r['events']} ({r['events_first']} in revolution 1) "
              f"({time.perf_counter() - t0:.1f} s wall)", flush=True)
        if events:
            print(f"rtol {rtol:g}: contact events per revolution "
                  + " ".join(str(n) for n in r["per_revolution"]))
    per = periodicity(runs)
    for k in range(revolutions):
        print(f"revolution {k + 1}: peaks " + " ".join(f"{r['peaks'][k]:.10g}" for r in runs)
              + f" N; between rtols {per['between_rtols'][k]:.2e}, change from the "
              f"previous revolution {per['rev_to_rev'][k]:.2e}")
    s = settled_summary(runs, first)
    span = f"revolutions {first}-{revolutions}"
    print(f"{span}: peak median {s['peak'][0]:.10g} N ({s['peak'][1]:.10g} to "
          f"{s['peak'][2]:.10g}) at rtol {min(rtols):g}; change between consecutive ones "
          f"{s['change'][0]:.2e} to {s['change'][2]:.2e} (median {s['change'][1]:.2e})"
          + ("" if s["between"] is None else
             f"; between rtols {s['between'][0]:.2e} to {s['between'][2]:.2e} "
             f"(median {s['between'][1]:.2e})"))
    for rtol, ev in zip(rtols, s["events"]):
        if ev is not None:
            print(f"{span}: contact events per revolution {ev[0]}-{ev[1]}, {ev[2]} in all, at "
                  f"rtol {rtol:g}")
    # how the motion approaches its orbit: the ratio of consecutive changes (geometric:
    # about constant) and each revolution's peak against the last one's, at the tightest rtol
    rev = per["rev_to_rev"][first:]
    ratios = rev[1:] / rev[:-1]
    if ratios.size and np.all(np.isfinite(ratios)):
        print(f"{span}: ratio of consecutive changes median {np.median(ratios):.2f} "
              f"({ratios.min():.2f} to {ratios.max():.2f}) from revolution {first + 2} on")
    tight = np.asarray(runs[int(np.argmin([r["rtol"] for r in runs]))]["peaks"])
    print(f"against revolution {revolutions}'s peak at rtol {min(rtols):g}: " + ", ".join(
        f"revolution {k + 1} {tight[k] / tight[-1] - 1:+.1e}" for k in range(revolutions - 1)))


def _override(text: str) -> tuple[str, float]:
    """NAME=VALUE of the command line; a crank speed may be in rpm (``crank_speed=20rpm``)."""
    key, sep, value = text.partition("=")
    if not sep:
        raise ValueError(f"an override is NAME=VALUE; got {text!r}")
    try:
        if key == "crank_speed" and value.endswith("rpm"):
            return key, float(value[:-3]) * math.pi / 30.0
        return key, float(value)
    except ValueError:
        raise ValueError(f"override {key}: the value must be a number; got {value!r}") from None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m validation.regime_scan",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("case", choices=sorted(cases.CASES))
    ap.add_argument("revolutions", type=int)
    ap.add_argument("steps", help="steps per revolution, or 'adaptive'")
    ap.add_argument("rest", nargs="*", metavar="RTOLS NAME=VALUE",
                    help="with 'adaptive' first the rtols (comma-separated); then overrides")
    ap.add_argument("--from", dest="first", type=int, default=2,
                    help="the summary's first revolution (adaptive; default 2)")
    ap.add_argument("--events", action="store_true",
                    help="contact events per revolution, from a recording run (adaptive)")
    args = ap.parse_intermixed_args(argv)
    adaptive = args.steps == "adaptive"
    if args.revolutions < (2 if adaptive else 1):
        ap.error(f"revolutions must be >= {2 if adaptive else 1}; got {args.revolutions}")
    try:
        if adaptive:
            if not args.rest:
                raise ValueError("'adaptive' needs the rtols (e.g. 1e-10,1e-11)")
            rtols = [float(r) for r in args.rest[0].split(",")]
            if not all(0 < r < 1 for r in rtols):
                raise ValueError(f"the rtols must be in (0, 1); got {args.rest[0]}")
            if not 2 <= args.first < args.revolutions:
                raise ValueError(f"--from must be in [2, {args.revolutions - 1}]; got "
                                 f"{args.first}")
            overrides = dict(_override(a) for a in args.rest[1:])
        else:
            steps = int(args.steps) if args.steps.isdigit() else 0
            if steps < 1 or args.events or args.first != 2:
                raise ValueError("steps must be 'adaptive' or a whole number >= 1 (--from "
                                 f"and --events go with 'adaptive'); got {args.steps!r}")
            overrides = dict(_override(a) for a in args.rest)
        linkage = cases.CASES[args.case](**overrides)
        period = linkage.period     # a free linkage has none: its error says so
    except ValueError as exc:
        ap.error(str(exc))
    if adaptive:
        main_adaptive(args.case, args.revolutions, rtols, overrides, args.first, args.events,
                      linkage)
        return 0
    model = load_model(linkage)
    p = pack_parameters(linkage, model)
    y0 = initial_state(linkage, model, p)
    run = make_runner(model)
    t0 = time.perf_counter()
    peaks, events = run(y0, p, period / steps, period, args.revolutions)
    print(f"{args.case} {overrides} h = {period / steps:.3g} s "
          f"({time.perf_counter() - t0:.1f} s wall)")
    for k, (peak, nev) in enumerate(zip(peaks, events), 1):
        print(f"revolution {k}: peak {peak:.6f} N, {nev} contact events")
    peaks = np.asarray(peaks, dtype=float)
    if peaks.size > 1:
        change = np.abs(np.diff(peaks)) / np.abs(peaks[1:])
        print("change from the previous revolution: " + ", ".join(
            f"revolution {k} {c:.1e}" for k, c in enumerate(change, 2)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
