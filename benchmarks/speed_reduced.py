"""Speed of the compiled reduced model against scipy solve_ivp on the same equations.

Paper case, 4 revolutions. The error measure is the relative error of the 4th-revolution
peak |F12| against a tight reference (compiled integrator at rtol 1e-12, checked against
scipy DOP853 at rtol 1e-12). scipy is timed at decreasing tolerances until its error is not
worse than ours; the headline ratio takes scipy's time at exactly our error, interpolated in
log(time) against log(error) between the last two tolerances (the loosest tolerance not
worse than ours is reported too: where scipy's error there is much smaller than ours, that
ratio overstates our lead). Medians over repeats, after JIT warm-up, all in one run.

    python -m benchmarks.speed_reduced [--repeats 20]
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys

from mbs_clearance import SliderCrank, peak_base_force, simulate
from mbs_clearance.solve.reduced import DEFAULT_RTOL
from validation.scipy_reference import solve_scipy
from validation.timing import machine_summary, paired, timed

FIRST_CALL = """
import time
t0 = time.perf_counter()
from mbs_clearance import SliderCrank, simulate
from mbs_clearance.core import build
t1 = time.perf_counter()
simulate(SliderCrank(), 4)
t2 = time.perf_counter()
print(t1 - t0, t2 - t1, build.compile_count())
"""


def equal_error_time(rows, error):
    """scipy's time at `error`, interpolated linearly in log(time) against log(error)
    between the last row whose error is above it and the first at or below it (rows
    (rtol, error, time, nfev) in order of decreasing rtol); None if no row reaches it."""
    for (_, e0, t0, _), (_, e1, t1, _) in zip(rows, rows[1:]):
        if e1 <= error < e0:
            w = math.log(e0 / error) / math.log(e0 / e1)
            return math.exp(math.log(t0) + w * math.log(t1 / t0))
    if rows and rows[0][1] <= error:
        return rows[0][2]
    return None


def equal_error_ratio(rows, ratios, error):
    """The speed ratio at `error`: the paired ratios of the rows (same order as rows)
    interpolated in log(ratio) against log(error) as `equal_error_time` does for times."""
    scaled = [(r[0], r[1], q, r[3]) for r, q in zip(rows, ratios)]
    return equal_error_time(scaled, error)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--scipy-repeats", type=int, default=3)
    ap.add_argument("--json", help="also write the results to this JSON file")
    args = ap.parse_args(argv)
    mech = SliderCrank()

    ref = peak_base_force(mech, 4, rtol=1e-12)
    ref_scipy = solve_scipy(mech, revolutions=4, rtol=1e-12).peaks[3]
    print(f"reference peak (ours, rtol 1e-12) = {ref:.6f} N; scipy DOP853 rtol 1e-12: "
          f"{ref_scipy:.6f} N (rel. diff {abs(ref_scipy / ref - 1):.1e})")

    simulate(mech, 4)  # warm-up (loads the cache or compiles)
    ours_err = abs(peak_base_force(mech, 4) / ref - 1)
    t_sim = timed(lambda: simulate(mech, 4), args.repeats)[0]
    t_peak = timed(lambda: peak_base_force(mech, 4), args.repeats)[0]

    rows = []
    ratios = []         # (simulate, peak only) of each scipy row, paired
    chosen = None
    for rtol in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
        res = solve_scipy(mech, revolutions=4, rtol=rtol)
        err = abs(res.peaks[3] / ref - 1)

        def run_scipy(r=rtol):
            return solve_scipy(mech, revolutions=4, rtol=r)

        sim = paired(lambda: simulate(mech, 4), run_scipy, args.scipy_repeats)
        peak = paired(lambda: peak_base_force(mech, 4), run_scipy, args.scipy_repeats)
        rows.append((rtol, err, sim["b"], res.nfev))
        ratios.append((sim["ratio"], peak["ratio"]))
        if chosen is None and err <= ours_err:
            chosen = (rtol, err, sim["b"], sim["ratio"], peak["ratio"])
            break

    out = subprocess.run([sys.executable, "-c", FIRST_CALL], capture_output=True, text=True,
                         check=True).stdout.split()
    t_import, t_first, misses = float(out[0]), float(out[1]), int(out[2])

    print()
    print(f"Machine: {machine_summary()}")
    print()
    print("| run (paper case, 4 revolutions) | rtol | peak rel. error | median time (ms) |")
    print("|---|---|---|---|")
    print(f"| ours, simulate (full trajectory) | {DEFAULT_RTOL:g} | {ours_err:.1e} | "
          f"{t_sim * 1e3:.2f} |")
    print(f"| ours, peak only | {DEFAULT_RTOL:g} | {ours_err:.1e} | {t_peak * 1e3:.2f} |")
    for rtol, err, t, nfev in rows:
        print(f"| scipy DOP853 (nfev {nfev}) | {rtol:g} | {err:.1e} | {t * 1e3:.1f} |")
    print()
    r_sim = equal_error_ratio(rows, [r[0] for r in ratios], ours_err)
    r_peak = equal_error_ratio(rows, [r[1] for r in ratios], ours_err)
    if r_sim is not None:
        print(f"scipy at our error ({ours_err:.1e}, interpolated): ours is {r_sim:.0f} x "
              f"faster (simulate), {r_peak:.0f} x faster (peak only), medians of "
              f"alternating pairs")
    if chosen:
        print(f"scipy at the loosest rtol not worse than ours ({chosen[0]:g}, error "
              f"{chosen[1]:.1e}): {chosen[2] * 1e3:.1f} ms "
              f"-> ours is {chosen[3]:.0f} x faster (simulate), "
              f"{chosen[4]:.0f} x faster (peak only)")
    print(f"new process: import {t_import:.2f} s, first simulate {t_first * 1e3:.1f} ms, "
          f"libraries compiled {misses} (0 = everything from the cache)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"ours_error": ours_err, "t_simulate": t_sim, "t_peak": t_peak,
                       "scipy": rows, "paired_ratios": ratios, "chosen": chosen,
                       "ratio_at_our_error": [r_sim, r_peak],
                       "first_call": [t_import, t_first, misses]}, fh, indent=1)


if __name__ == "__main__":
    main()
