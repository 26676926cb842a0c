"""Speed and accuracy of the Exudyn backend's contact variants against the reduced model.

Paper case, 4 revolutions, full trajectories (``simulate``). Error measures against a tight
reference, the reduced model at rtol 1e-11 (h_max 2e-7 s, so that its samples are dense):
the relative error of the 4th-revolution peak |F12| and the relative RMS differences of F12
and of the crank moment over the 4th revolution (`validation.compare`). Wall times are
medians over repeats, measured after a warm-up run, all in one process and one run.

    python -m validation.benchmarks.exudyn_speed [--repeats 3] [--step-sizes 5e-6 2e-6 1e-6]
"""

from __future__ import annotations

import argparse
import json

from mbs_clearance import SliderCrank, simulate
from mbs_clearance.exudyn_model import CONTACT_VARIANTS, DEFAULT_STEP_SIZE
from mbs_clearance.reduced import DEFAULT_RTOL
from validation.benchmarks.common import machine_summary, timed
from validation.compare import compare


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per Exudyn setting")
    ap.add_argument("--reduced-repeats", type=int, default=20)
    ap.add_argument("--step-sizes", type=float, nargs="+", default=[5e-6, DEFAULT_STEP_SIZE, 1e-6])
    ap.add_argument("--contacts", nargs="+", default=list(CONTACT_VARIANTS),
                    choices=CONTACT_VARIANTS)
    ap.add_argument("--json", help="also write the results to this JSON file")
    args = ap.parse_args(argv)
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
        m = compare(ref, traj, revolutions=(rev,)).revolution(rev)
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


if __name__ == "__main__":
    main()
