"""Cost of the oil film: the paper case with its coupler-slider joint lubricated (the
short film, SAE 30 oil at 100 C, `cases.paper_slider_crank_lubricated`) against the dry
joint (`cases.paper_slider_crank`), at equal accuracy (each run at the default accuracy of
`simulate`, which tightens its tolerance until its peaks agree).

A/B in one process, alternating (dry, lubricated, ...): the median of the per-pair time
ratios lubricated / dry for a full `simulate` of 4 revolutions, with the right-hand side
evaluations of both and their revolution-4 peaks, after one line on why the film is stiff
(`film_stiffness`). The budget: 2. `--method` runs the
lubricated case with another integration method (e.g. rodas4, linearly implicit), `--rtol`
at a fixed tolerance instead of the default accuracy (both runs).

    python -m benchmarks.lubrication_speed [--repeats 5] [--viscosity 9e-3] [--method rodas4]
        [--rtol 1e-8]
"""

from __future__ import annotations

import argparse
import math

from mbs_clearance import SliderCrank, simulate
from mbs_clearance.model.cases import paper_slider_crank, paper_slider_crank_lubricated
from validation.timing import machine_summary, paired


def film_stiffness(lube, eps: float = 0.5, rtol: float = 1e-8) -> str:
    """Why the film is stiff, in one line: the short film's squeeze damping
    R mu L^3 pi (1 + 2 eps^2) / (2 c^3 (1 - eps^2)^(5/2)) (N s/m) at `eps`, its time
    constant on the slider's mass, and the film force (N) of a velocity error of the crank
    pin's speed times `rtol`."""
    joint, paper = lube.clearance_joints[0], SliderCrank()
    c = joint.bearing_radius - joint.journal_radius
    damping = (joint.journal_radius * joint.viscosity * joint.bearing_length**3 * math.pi
               * (1 + 2 * eps**2) / (2 * c**3 * (1 - eps**2) ** 2.5))
    error = paper.crank_length * paper.crank_speed * rtol
    return (f"film squeeze damping at eps {eps:g}: {damping:.1e} N s/m, a time constant of "
            f"{paper.slider_mass / damping:.1e} s on the slider's {paper.slider_mass:g} kg; a "
            f"velocity error of {error:.1e} m/s (the crank pin's speed x rtol {rtol:g}) is "
            f"{damping * error:.2g} N of film force")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--viscosity", type=float, default=9e-3, help="Pa s")
    parser.add_argument("--method", default="dopri5", help="the lubricated run's method")
    parser.add_argument("--rtol", type=float, default=None, help="fixed rtol of both runs")
    args = parser.parse_args(argv)
    dry = paper_slider_crank()
    lube = paper_slider_crank_lubricated(viscosity=args.viscosity)
    fixed = {} if args.rtol is None else {"rtol": args.rtol}
    print(machine_summary())
    print(f"lubricated run: method {args.method}, "
          + ("default accuracy" if args.rtol is None else f"rtol {args.rtol:g}"))
    a = simulate(dry, 4, **fixed)                      # compile / load both
    b = simulate(lube, 4, method=args.method, **fixed)
    print(film_stiffness(lube))
    print(f"viscosity {args.viscosity} Pa s: nfev dry {a.stats['nfev']}, lubricated "
          f"{b.stats['nfev']} (ratio {b.stats['nfev'] / a.stats['nfev']:.1f}); rev-4 peak "
          f"dry {a.max_base_force(4):.6g} N, lubricated {b.max_base_force(4):.6g} N")
    r = paired(lambda: simulate(dry, 4, **fixed),
               lambda: simulate(lube, 4, method=args.method, **fixed), args.repeats)
    print(f"simulate, 4 revolutions: dry {r['a'] * 1e3:.1f} ms, lubricated "
          f"{r['b'] * 1e3:.1f} ms, median ratio of pairs {r['ratio']:.1f} (budget 2)")


if __name__ == "__main__":
    main()
