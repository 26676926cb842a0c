"""Speed and accuracy of the Exudyn backend's contact variants against the reduced model.

Paper case, 4 revolutions, full trajectories (``simulate``). Error measures against a tight
reference, the reduced model at rtol 1e-11 (h_max 2e-7 s, so that its samples are dense):
the relative error of the 4th-revolution peak |F12| and the relative RMS differences of F12
and of the crank moment over the 4th revolution (`validation.compare`). Wall times are
medians over repeats, measured after a warm-up run, all in one process and one run.

    python -m benchmarks.exudyn_speed [--repeats 3] [--step-sizes 5e-6 2e-6 1e-6]

With ``--cases NAME ...`` (or ``--cases all``) it measures the named linkages instead (the
models generated from their descriptions, `cases.CASES`): per case the reduced model's
default run (rtol 1e-7) and its 4th-revolution (four-bar: 2nd, `COMPARED_REVOLUTION`) peak
error against the reduced model at rtol 1e-11, Exudyn at its default step and at that step
times 2, 1/2, 1/4 (``--factors``), each with its
peak error, and Exudyn's time at the reduced default's error (interpolated in log-log
between the two bracketing steps, second order) with our speed-up at equal error:

    python -m benchmarks.exudyn_speed --cases all [--repeats 3]

With ``--settled N`` every run of a case (references, reduced default, Exudyn) starts from
the reduced model's state after N revolutions (`linkage_model.settled_start`, rtol 1e-10)
and the measure is the 1st revolution from there: the periodic response without the
start's transient (the four-bar's default settles after about 100 revolutions).
"""

from __future__ import annotations

import argparse
import json

from mbs_clearance import SliderCrank, simulate
from mbs_clearance.backends.exudyn_model import CONTACT_VARIANTS, DEFAULT_STEP_SIZE
from mbs_clearance.solve.reduced import DEFAULT_RTOL
from validation.compare import compare
from validation.timing import machine_summary, timed


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per Exudyn setting")
    ap.add_argument("--reduced-repeats", type=int, default=20)
    ap.add_argument("--step-sizes", type=float, nargs="+", default=[5e-6, DEFAULT_STEP_SIZE, 1e-6])
    ap.add_argument("--contacts", nargs="+", default=list(CONTACT_VARIANTS),
                    choices=CONTACT_VARIANTS)
    ap.add_argument("--json", help="also write the results to this JSON file")
    ap.add_argument("--cases", nargs="+", metavar="NAME",
                    help="named linkages to measure (or 'all') instead of the contact variants")
    ap.add_argument("--factors", type=float, nargs="+", default=[2.0, 1.0, 0.5, 0.25],
                    help="with --cases: Exudyn's steps as multiples of its default step")
    ap.add_argument("--settled", type=int, default=0, metavar="N",
                    help="with --cases: start from the state after N revolutions")
    ap.add_argument("--spectral-radius", type=float, default=0.9,
                    help="with --cases: Exudyn's spectral radius (numerical damping; "
                         "default 0.9, the backend's)")
    ap.add_argument("--newton-tolerance", type=float, default=None,
                    help="with --cases: Exudyn's Newton tolerance (default: the backend's "
                         "rule, docs/exudyn.md)")
    args = ap.parse_args(argv)
    if args.cases:
        return cases_main(args)
    mech = SliderCrank()
    rev = 4

    ref = simulate(mech, rev, backend="reduced", rtol=1e-11, h_max=2e-7)
    ref_peak = ref.max_base_force(rev)
    print(f"reference: reduced model, rtol 1e-11, 4th-revolution peak |F12| = {ref_peak:.4f} N",
          flush=True)

    runs = [("reduced", f"rtol {rtol:g}", dict(rtol=rtol), args.reduced_repeats)
            for rtol in (DEFAULT_RTOL, 1e-10)]
    runs += [("exudyn", f"{contact}, h = {h:g} s", dict(contact=contact, step_size=h),
              args.repeats) for contact in args.contacts for h in args.step_sizes]
    rows = []
    for backend, label, options, repeats in runs:
        simulate(mech, rev, backend=backend, **options)          # warm-up
        t, traj = timed(lambda b=backend, o=options: simulate(mech, rev, backend=b, **o),
                              repeats)
        m = compare(ref, traj, revolutions=(rev,), step_bars=False).revolution(rev)
        rows.append(dict(backend=backend, setting=label, time=t, repeats=repeats,
                         peak=traj.max_base_force(rev), peak_error=abs(m.peak_rel_diff),
                         rms_f12=m.base_force_rel_rms, rms_m2=m.crank_moment_rel_rms,
                         samples=len(traj.t)))
        print(f"  {backend:8s} {label:28s} {t:8.3f} s  peak error {abs(m.peak_rel_diff):.1e}",
              flush=True)

    print()
    print(f"Machine: {machine_summary()}")
    print()
    print("| backend | setting | median time (s) | 4th-rev. peak abs(F12) (N) | peak rel. error "
          "| rel. RMS diff. F12, rev. 4 | rel. RMS diff. M2, rev. 4 |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['backend']} | {r['setting']} | {r['time']:.3f} | {r['peak']:.2f} | "
              f"{r['peak_error']:.1e} | {r['rms_f12']:.1e} | {r['rms_m2']:.1e} |")
    print()
    print(f"reference peak {ref_peak:.4f} N (reduced, rtol 1e-11); medians of "
          f"{args.repeats} (Exudyn) / {args.reduced_repeats} (reduced) runs after a warm-up")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"reference_peak": ref_peak, "rows": rows,
                       "machine": machine_summary()}, fh, indent=1)


def _interpolated_time(rows: list[dict], target: float) -> float | None:
    """Exudyn's time at peak error `target`, log-log interpolated between the two runs whose
    errors bracket it (None if none do)."""
    import math

    pts = sorted((r["peak_error"], r["time"]) for r in rows if r["peak_error"] > 0)
    for (e0, t0), (e1, t1) in zip(pts[:-1], pts[1:]):
        if e0 <= target <= e1:
            w = math.log(target / e0) / math.log(e1 / e0) if e1 > e0 else 0.0
            return math.exp(math.log(t0) + w * (math.log(t1) - math.log(t0)))
    return None


#: the revolution compared per case (default 4): the four-bar is not periodic (its sliding
#: mode decays over many revolutions, docs/exudyn.md) and its Exudyn step is 1.56e-5 s, so
#: its 2nd revolution is measured (its peak error does not fall regularly with the step)
COMPARED_REVOLUTION = {"four_bar": 2}


def cases_main(args) -> None:
    """The named linkages: reduced default vs Exudyn at several steps (module docstring)."""
    from mbs_clearance.backends.exudyn_linkage import make_settings
    from mbs_clearance.model.cases import CASES
    from mbs_clearance.solve.linkage_model import DEFAULT_RTOL as LINKAGE_RTOL
    from mbs_clearance.solve.linkage_model import settled_start

    names = sorted(CASES) if args.cases == ["all"] else args.cases
    out = []
    for name in names:
        lk = CASES[name]()
        start = settled_start(lk, args.settled, rtol=1e-10) if args.settled else None
        rev = 1 if start is not None else COMPARED_REVOLUTION.get(name, 4)
        h0 = make_settings({}).step(lk)
        ref = simulate(lk, rev, backend="reduced", rtol=1e-11, start=start)
        ref_peak = ref.max_base_force(rev)
        simulate(lk, rev, backend="reduced", start=start)            # warm-up
        t_red, red = timed(lambda lk=lk, rev=rev, st=start: simulate(
            lk, rev, backend="reduced", start=st), args.reduced_repeats)
        err_red = abs(red.max_base_force(rev) / ref_peak - 1)
        rows = []
        for factor in args.factors:
            h = h0 * factor
            try:
                t, tr = timed(lambda lk=lk, h=h, rev=rev, st=start: simulate(
                    lk, rev, backend="exudyn", step_size=h, start=st,
                    spectral_radius=args.spectral_radius,
                    newton_tolerance=args.newton_tolerance), args.repeats)
            except RuntimeError as exc:          # Exudyn's Newton failed at this step
                print(f"  {name} exudyn h = {h:.3g} s: failed ({exc})", flush=True)
                continue
            m = compare(ref, tr, revolutions=(rev,), step_bars=False).revolution(rev)
            rows.append(dict(step=h, time=t, peak_error=abs(m.peak_rel_diff),
                             rms_shaking=abs(m.shaking_rms_rel_diff),
                             rms_moment=abs(m.moment_rms_rel_diff)))
            print(f"  {name} exudyn h = {h:.3g} s: {t:.3f} s, peak error "
                  f"{abs(m.peak_rel_diff):.1e}", flush=True)
        t_equal = _interpolated_time(rows, err_red)
        out.append(dict(case=name, revolution=rev, reduced_rtol=LINKAGE_RTOL, reduced_time=t_red,
                        reduced_peak_error=err_red, exudyn=rows, exudyn_time_at_equal_error=
                        t_equal, speedup=None if t_equal is None else t_equal / t_red))
    print()
    print(f"Machine: {machine_summary()}")
    print()
    if args.settled:
        print(f"Every run from the state after {args.settled} revolutions; revolution 1 "
              "from there.")
    print(f"Exudyn's spectral radius: {args.spectral_radius:g}")
    print("| case | revolution | reduced (rtol 1e-7): time (s), peak error | Exudyn step (s) | "
          "time (s) | peak error | RMS shaking | RMS moment |")
    print("|---|---|---|---|---|---|---|---|")
    for c in out:
        for r in c["exudyn"]:
            print(f"| {c['case']} | {c['revolution']} | {c['reduced_time']:.4f}, "
                  f"{c['reduced_peak_error']:.1e} | "
                  f"{r['step']:.3g} | {r['time']:.3f} | {r['peak_error']:.1e} | "
                  f"{r['rms_shaking']:.1e} | {r['rms_moment']:.1e} |")
    print()
    print("| case | Exudyn time at the reduced default's error (s) | speed-up |")
    print("|---|---|---|")
    for c in out:
        te, su = c["exudyn_time_at_equal_error"], c["speedup"]
        print(f"| {c['case']} | {'outside the measured steps' if te is None else f'{te:.3f}'}"
              f" | {'-' if su is None else f'{su:.0f} x'} |")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"cases": out, "machine": machine_summary()}, fh, indent=1)


if __name__ == "__main__":
    main()
