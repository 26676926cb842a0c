"""Cost of the oil film: the paper case with its coupler-slider joint lubricated (the
short film, SAE 30 oil at 100 C, `cases.paper_slider_crank_lubricated`) against the dry
joint (`cases.paper_slider_crank`), at equal accuracy (each run at the default accuracy of
`simulate`, which tightens its tolerance until its peaks agree).

A/B in one process, alternating (dry, lubricated, ...): the median of the per-pair time
ratios lubricated / dry for a full `simulate` of 4 revolutions, with the right-hand side
evaluations of both and their revolution-4 peaks. The budget: 2.

    python -m benchmarks.lubrication_speed [--repeats 5] [--viscosity 9e-3]
"""

from __future__ import annotations

import argparse

from mbs_clearance import simulate
from mbs_clearance.model.cases import paper_slider_crank, paper_slider_crank_lubricated
from validation.timing import machine_summary, paired


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--viscosity", type=float, default=9e-3, help="Pa s")
    args = parser.parse_args(argv)
    dry = paper_slider_crank()
    lube = paper_slider_crank_lubricated(viscosity=args.viscosity)
    print(machine_summary())
    a = simulate(dry, 4)                      # compile / load both
    b = simulate(lube, 4)
    print(f"viscosity {args.viscosity} Pa s: nfev dry {a.stats['nfev']}, lubricated "
          f"{b.stats['nfev']} (ratio {b.stats['nfev'] / a.stats['nfev']:.1f}); rev-4 peak "
          f"dry {a.max_base_force(4):.6g} N, lubricated {b.max_base_force(4):.6g} N")
    r = paired(lambda: simulate(dry, 4), lambda: simulate(lube, 4), args.repeats)
    print(f"simulate, 4 revolutions: dry {r['a'] * 1e3:.1f} ms, lubricated "
          f"{r['b'] * 1e3:.1f} ms, median ratio of pairs {r['ratio']:.1f} (budget 2)")


if __name__ == "__main__":
    main()
