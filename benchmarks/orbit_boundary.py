"""The period-1 boundary of the paper's case over clearance at 5000 rpm, or over crank speed
at 0.01 mm (--field crank_speed, downwards from 5000 rpm): continuation from the paper's
design to its first period doubling (`continue_orbits`, stop_at_first), and
the brute-force classification (100 revolutions, 50 kept, the regime map's rule) at
clearances around it, from two starts: the centred start of the regime map, and the
branch's orbit nearest below (a matched start: its state and held impact velocity, the
journal's memory the branch follows).

Prints the located doubling (also in mm or rpm, with the memory the branch holds), then
per clearance the regime from each start, and the brute-force boundary (the last period-1
value and the next) from each.

    python -m benchmarks.orbit_boundary [--points 9] [--width 2e-8]
    python -m benchmarks.orbit_boundary --field crank_speed [--points 9] [--width 2]
    python -m benchmarks.orbit_boundary --field crank_speed --max-step 3 --max-points 200
    python -m benchmarks.orbit_boundary --memories [--points 9]

--max-step and --max-points are the continuation's (default: 30 rad/s and 1500 orbits over
crank speed, `continue_orbits`' own over clearance); a branch that ends before a doubling
is printed with the value it reached, and nothing is run around it.

--memories runs only the centred start (100 revolutions, the regime map's flow) at
--points clearances from 0.01 to 0.03 mm at 5000 rpm and prints the memory (the joint's
held impact velocity) each settles on, then their range.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from mbs_clearance import SliderCrank, continue_orbits, poincare_section
from mbs_clearance.analysis.periodic import with_field
from mbs_clearance.analysis.poincare import Flow, classify, scale_samples, section_times
from validation.timing import machine_summary


def matched_regime(mech, state, modes, vel, revolutions=100, keep=50):
    """The regime map's rule on a plain run started from (state, modes, vel)."""
    flow = Flow(mech)
    n2 = len(state)
    mem = flow.model.MEM_START
    flow.y[:n2] = state
    flow.p[mem:mem + 2 * len(modes):2] = modes
    flow.p[mem + 1:mem + 2 * len(modes):2] = vel
    samples = []
    for k, t in enumerate(section_times(mech, revolutions)):
        flow.advance(t)
        if k >= revolutions - keep:
            samples.append(flow.section())
    scaled = scale_samples(np.array(samples), flow.clearance, flow.omega)
    regime, period, d = classify(scaled)
    return regime, period, float(d[0])


def centred_memory(mech, revolutions=100) -> float:
    """The impact velocity (m/s) the joint's memory holds after `revolutions` of the
    regime map's flow from the centred start."""
    flow = Flow(mech)
    for t in section_times(mech, revolutions):
        flow.advance(t)
    return float(flow.p[flow.model.MEM_START + 1])


def memories(points: int) -> None:
    """The memory the centred start settles on at `points` clearances, 0.01 - 0.03 mm."""
    paper = SliderCrank()
    found = []
    for c in np.linspace(1e-5, 3e-5, points):
        found.append(centred_memory(with_field(paper, "clearance", c)))
        print(f"clearance {c * 1e3:.4g} mm: centred start settles on the memory "
              f"{found[-1]:.3g} m/s")
    print(f"memories from the centred start: {min(found):.2g} - {max(found):.2g} m/s "
          f"at {points} clearances from 0.01 to 0.03 mm")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=9)
    ap.add_argument("--field", choices=("clearance", "crank_speed"), default="clearance")
    ap.add_argument("--width", type=float, default=None,
                    help="values within +- width of the doubling (default 2e-8 m of "
                         "clearance, 2 rad/s of crank speed)")
    ap.add_argument("--max-step", type=float, default=None,
                    help="the continuation's largest step (default 30 rad/s over crank "
                         "speed, continue_orbits' default over clearance)")
    ap.add_argument("--max-points", type=int, default=None,
                    help="orbits of the continuation at most (default 1500 over crank "
                         "speed, 400 over clearance)")
    ap.add_argument("--memories", action="store_true",
                    help="only the memories the centred start settles on, 0.01 - 0.03 mm")
    args = ap.parse_args(argv)
    if args.points < 1:
        ap.error(f"--points must be >= 1; got {args.points}")
    if args.max_step is not None and not args.max_step > 0:
        ap.error(f"--max-step must be > 0; got {args.max_step}")
    if args.max_points is not None and args.max_points < 2:
        ap.error(f"--max-points must be >= 2; got {args.max_points}")
    print(machine_summary())
    if args.memories:
        memories(args.points)
        return 0
    paper = SliderCrank()
    t0 = time.perf_counter()
    if args.field == "clearance":
        width = 2e-8 if args.width is None else args.width
        step = {} if args.max_step is None else {"max_step": args.max_step}
        branch = continue_orbits(paper, "clearance", 1e-5, 2e-5,
                                 max_points=args.max_points or 400, stop_at_first=True,
                                 **step)
    else:
        width = 2.0 if args.width is None else args.width
        branch = continue_orbits(paper, "crank_speed", paper.crank_speed,
                                 1000 * math.pi / 30, max_points=args.max_points or 1500,
                                 max_step=args.max_step or 30.0, stop_at_first=True)
    print(f"{branch.summary()}\n({time.perf_counter() - t0:.1f} s, "
          f"{branch.counters['shooting_runs']} variational and "
          f"{branch.counters['plain_runs']} plain runs)")
    if not branch.points:
        last = branch.values[-1]
        print("no period doubling on the branch; it reaches "
              + (f"{last:.6g} m" if args.field == "clearance" else
                 f"{last * 30 / math.pi:.0f} rpm ({last:.6g} rad/s)")
              + f" after {len(branch.values)} orbits")
        return 0
    pd = branch.points[0]
    at = (f"{pd.value * 1e3:.6g} mm" if args.field == "clearance"
          else f"{pd.value * 30 / math.pi:.5g} rpm")
    print(f"first period doubling at {at}; the memory held at "
          f"{branch.impact_velocities[0, 0]:.4g} m/s (the design's settled value)")
    # the branch's side of the doubling (it starts at the paper's design)
    below = (branch.values < pd.value) == (branch.values[0] < pd.value)
    for c in np.linspace(pd.value - width, pd.value + width, args.points):
        mech = with_field(paper, args.field, c)
        centred = poincare_section(mech, 100, 50)
        i = int(np.argmin(np.where(below, np.abs(branch.values - c), math.inf)))
        reg, per, d1 = matched_regime(mech, branch.states[i], np.ones(1),
                                      branch.impact_velocities[i])
        where = (f"clearance {c:.10g} m ({(c - pd.value) * 1e9:+.1f} nm" if
                 args.field == "clearance" else
                 f"crank speed {c * 30 / math.pi:.6g} rpm ({c - pd.value:+.3g} rad/s")
        print(f"{where} from the doubling): "
              f"centred start {centred.regime}/{centred.period}, matched start "
              f"{reg}/{per} (d1 {d1:.2g})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
