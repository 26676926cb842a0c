"""The paper case as a `SliderCrank` against the same case as a `Linkage` description.

Both run on the same compiled model (the paper case's):
the SliderCrank through reduced.py's orchestration (closed-form centred start, its
Trajectory), the Linkage through linkage_model's glue (Newton on the loop closure, the
per-joint Trajectory). A/B in one process, alternating (SliderCrank, Linkage, ...): the
median of the per-pair time ratios Linkage / SliderCrank, for a full `simulate` (4
revolutions, every step recorded) and for the peak only (`peak_base_force`), at the default
rtol; with the peaks and function evaluations of both (the same events, peaks within 1e-9).
The ratio is the glue's overhead; whether the paper case got slower than the hand-written
kernels it replaced is measured across commits with `integrator_ab` (docs/performance.md).

    python -m benchmarks.linkage_speed [--repeats 41]
"""

from __future__ import annotations

import argparse

from mbs_clearance import SliderCrank, peak_base_force, simulate
from mbs_clearance.model.cases import paper_slider_crank
from validation.timing import machine_summary, paired


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=41)
    args = parser.parse_args(argv)
    mech, lk = SliderCrank(), paper_slider_crank()
    ref, gen = simulate(mech, 4), simulate(lk, 4)        # compile / load, then compare
    print(machine_summary())
    print(f"rev-4 peak: SliderCrank {ref.max_base_force(4):.10g} N, Linkage "
          f"{gen.max_base_force(4):.10g} N (relative difference "
          f"{gen.max_base_force(4) / ref.max_base_force(4) - 1:.2e})")
    print(f"nfev: SliderCrank {ref.stats['nfev']}, Linkage {gen.stats['nfev']}; events "
          f"{ref.stats['nevent']}, {gen.stats['nevent']}")
    for what, fa, fb in (
            ("simulate, 4 revolutions", lambda: simulate(mech, 4), lambda: simulate(lk, 4)),
            ("peak only, revolution 4", lambda: peak_base_force(mech, 4),
             lambda: peak_base_force(lk, 4))):
        r = paired(fa, fb, args.repeats)
        ratio, ta, tb = r["ratio"], r["a"], r["b"]
        print(f"{what:<26} SliderCrank {ta * 1e3:7.3f} ms, Linkage {tb * 1e3:7.3f} ms, "
              f"median ratio of pairs {ratio:.3f}")


if __name__ == "__main__":
    main()
