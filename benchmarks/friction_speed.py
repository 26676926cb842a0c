"""Cost of friction in a clearance joint: the paper case with friction against without.

A/B in one process, alternating (frictionless, friction, ...): the median of the per-pair
time ratios friction / frictionless for a full `simulate` (4 revolutions, every step
recorded) and for the peak only (`peak_base_force`), at the default rtol, for the paper case
(checked-in modules paper_slider_crank and paper_slider_crank_friction) with Ambrosio's law at
mu = 0.1 and mu = 0.01; with the function evaluations of both (the evaluation count's ratio
is pinned in tests/integration/test_friction_physics.py), and those of the two-joint case
at mu = 0.1 at rtol 1e-7 (not timed; `simulate`'s accuracy check reruns its friction run at
1e-8). The budget: 1.3.

    python -m benchmarks.friction_speed [--repeats 41]
"""

from __future__ import annotations

import argparse

from mbs_clearance import peak_base_force, simulate
from mbs_clearance.model.cases import paper_slider_crank, slider_crank_two_clearances
from validation.timing import machine_summary, paired


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=41)
    args = parser.parse_args(argv)
    plain = paper_slider_crank()
    print(machine_summary())
    ref = simulate(plain, 4)                  # compile / load
    for mu in (0.1, 0.01):
        fric = paper_slider_crank(friction_law="ambrosio", friction_coefficient=mu)
        run = simulate(fric, 4)
        print(f"mu = {mu}: nfev frictionless {ref.stats['nfev']}, friction "
              f"{run.stats['nfev']} (ratio {run.stats['nfev'] / ref.stats['nfev']:.3f}); "
              f"rev-4 peak {ref.max_base_force(4):.6g} N -> {run.max_base_force(4):.6g} N")
        for what, fa, fb in (
                ("simulate, 4 revolutions", lambda: simulate(plain, 4),
                 lambda lk=fric: simulate(lk, 4)),
                ("peak only, revolution 4", lambda: peak_base_force(plain, 4),
                 lambda lk=fric: peak_base_force(lk, 4))):
            r = paired(fa, fb, args.repeats)
            print(f"  {what:<26} frictionless {r['a'] * 1e3:7.3f} ms, friction "
                  f"{r['b'] * 1e3:7.3f} ms, median ratio of pairs {r['ratio']:.3f}")
    # at the default rtol as given: the accuracy check would rerun the friction run
    two = simulate(slider_crank_two_clearances(), 4, rtol=1e-7)
    two_fric = simulate(slider_crank_two_clearances(friction_law="ambrosio",
                                                    friction_coefficient=0.1), 4, rtol=1e-7)
    print(f"two joints, mu = 0.1, rtol 1e-7: nfev frictionless {two.stats['nfev']}, friction "
          f"{two_fric.stats['nfev']} (ratio {two_fric.stats['nfev'] / two.stats['nfev']:.3f})")


if __name__ == "__main__":
    main()
