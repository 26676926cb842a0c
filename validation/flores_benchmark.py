"""The translational-clearance benchmark of Flores, Leine and Glocker (2010) from two schools:
the package's compliant model (`cases.flores_translational_slider_crank`, event-located
corner contacts) against the nonsmooth reference (`validation.moreau`, rigid contacts and
Moreau's midpoint time stepping, the source's method).

    python -m validation.flores_benchmark --out DIR [--quick]

It converges each model on its own before comparing them:
- the compliant model over its contact stiffness (the stand-in for rigid contact) and its
  tolerance;
- the Moreau scheme over its step, whose error it measures in the free flight before the
  first impact (exact there) and extrapolates at the end (first order, Richardson).

It writes ``flores_benchmark.json`` (the numbers of docs/cases/flores_translational_slider_
crank.md) and three figures: the crank's revolutions over time, each corner's position
across the guide over c, and which corners touch when.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from . import moreau as mo

#: the corners of the case's joint "guide", in the order of `validation.moreau.CORNERS`
#: ((+a, +b), (-a, +b), (-a, -b), (+a, -b))
CORNER_NAMES = ("front_top", "rear_top", "rear_bottom", "front_bottom")
#: opposite corners (a jammed slider) and adjacent ones on one surface (flat)
OPPOSITE = (("front_top", "rear_bottom"), ("rear_top", "front_bottom"))
ADJACENT = (("front_top", "rear_top"), ("front_bottom", "rear_bottom"))


#: the regularised Coulomb law's (friction_v0, friction_v1) in m/s: the case's default, then
#: narrower; as v1 shrinks the law tends to the set-valued one, which can stick
REGULARISATIONS = ((1e-4, 1e-2), (1e-5, 1e-3), (1e-6, 1e-4))


def compliant_run(stiffness: float, rtol: float, duration: float, **overrides):
    """The package's model of the case at `stiffness` (N/m^1.5) and `rtol` (other case
    overrides as keywords): a dict of t, q (crank, coupler, slider angles), u, the corners'
    offsets over c and contact flags (in `CORNER_NAMES` order), and the run's wall time and
    counts."""
    from mbs_clearance import simulate
    from mbs_clearance.model.cases import flores_translational_slider_crank

    lk = flores_translational_slider_crank(contact_stiffness=stiffness, **overrides)
    t0 = time.perf_counter()
    tr = simulate(lk, duration=duration, rtol=rtol)
    wall = time.perf_counter() - t0
    names = ("crank.angle", "coupler.angle", "slider.angle")
    col = {n: i for i, n in enumerate(tr.joints)}
    idx = [col[f"guide.{c}"] for c in CORNER_NAMES]
    c = lk.translational_joints[0].clearance
    sy = np.array([1.0, 1.0, -1.0, -1.0])
    # penetration = sy * (corner's y offset) - c, so the offset over c is sy (pen / c + 1)
    offsets = sy * (tr.penetration[:, idx] / c + 1.0)
    return {"t": tr.t, "q": np.column_stack([tr.coordinates[n] for n in names]),
            "u": np.column_stack([tr.rates[n] for n in names]), "offsets": offsets,
            "contact": tr.penetration[:, idx] > 0.0, "wall": wall,
            "nfev": int(tr.stats.get("nfev", 0)), "max_penetration": float(
                np.max(tr.penetration[:, idx]) / c)}


def moreau_run(h: float, duration: float, sample: float = 1e-5):
    """The Moreau reference at step h, sampled every `sample` s."""
    d = mo.FLGData()
    t0 = time.perf_counter()
    r = mo.run(d, t_end=duration, h=h, every=max(1, int(round(sample / h))))
    wall = time.perf_counter() - t0
    return {"t": r.t, "q": r.q, "u": r.u, "offsets": r.corner_offsets(d),
            "contact": r.impulses > 0.0, "wall": wall, "steps": r.stats["steps"]}


def _energy(run) -> float:
    """Kinetic plus gravitational energy (J) at the run's end: both models have the same
    bodies and coordinates (absolute angles), so one formula serves both; the compliant
    model's contact energy is left out (no corner touches at the end of either run)."""
    return float(mo.energy(mo.FLGData(), run["q"][-1], run["u"][-1]))


def first_contact(run) -> float:
    hit = np.flatnonzero(run["contact"].any(axis=1))
    return float(run["t"][hit[0]]) if hit.size else math.nan


def first_impact_duration(run) -> float:
    """How long (s) the first contact lasts, from its first step in contact to the first
    step out of it (a rigid impact lasts no time)."""
    touching = run["contact"].any(axis=1)
    hit = np.flatnonzero(touching)
    if not hit.size:
        return math.nan
    out = np.flatnonzero(~touching[hit[0]:])
    return float(run["t"][hit[0] + out[0]] - run["t"][hit[0]]) if out.size else math.nan


def contact_summary(run) -> dict:
    """Per corner: its first contact time and the number of contact episodes; the time
    shares of flat (two adjacent corners) and jammed (two opposite) contact."""
    t, flags = run["t"], run["contact"]
    dt = np.diff(t, prepend=t[0])
    out = {"corners": {}}
    for k, name in enumerate(CORNER_NAMES):
        on = flags[:, k]
        starts = np.flatnonzero(on[1:] & ~on[:-1]) + 1
        episodes = int(starts.size + (1 if on[0] else 0))
        out["corners"][name] = {
            "first": float(t[np.argmax(on)]) if on.any() else None, "episodes": episodes}
    k = {n: i for i, n in enumerate(CORNER_NAMES)}
    span = float(t[-1] - t[0])
    for label, pairs in (("flat_share", ADJACENT), ("jammed_share", OPPOSITE)):
        both = np.zeros(len(t), dtype=bool)
        for a, b in pairs:
            both |= flags[:, k[a]] & flags[:, k[b]]
        out[label] = float(np.sum(dt[both]) / span)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m validation.flores_benchmark",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="output folder")
    ap.add_argument("--quick", action="store_true",
                    help="fewer stiffnesses and Moreau steps (about a minute)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    from mbs_clearance.model.cases import FLORES_DURATION as T

    stiffnesses = [1e9, 1e10, 1e11] if args.quick else [1e9, 1e10, 1e11, 1e12]
    steps = [2e-5, 1e-5] if args.quick else [2e-5, 1e-5, 5e-6, 2.5e-6]
    result = {"duration": T, "energy_start": float(mo.energy(mo.FLGData(), mo.FLGData().q0,
                                                              mo.FLGData().u0)),
              "compliant": {}, "moreau": {}}
    print(f"energy at the start {result['energy_start']:.4f} J", flush=True)

    runs = {}
    for K in stiffnesses:
        for rtol in (1e-8, 1e-10):
            r = compliant_run(K, rtol, T)
            runs[(K, rtol)] = r
            result["compliant"][f"K={K:g} rtol={rtol:g}"] = {
                "crank_angle_end": float(r["q"][-1, 0]),
                "energy_end": _energy(r),
                "crank_rate_end": float(r["u"][-1, 0]),
                "slider_angle_end": float(r["q"][-1, 2]),
                "first_contact": first_contact(r),
                "first_impact_duration": first_impact_duration(r), "max_penetration_over_c":
                    r["max_penetration"], "nfev": r["nfev"], "wall_s": r["wall"],
                **contact_summary(r)}
            print(f"compliant K={K:g} rtol={rtol:g}: crank {r['q'][-1, 0]:.5f} rad, "
                  f"{r['u'][-1, 0]:.4f} rad/s, energy {_energy(r):.5f} J, largest "
                  f"penetration / c {r['max_penetration']:.3g} ({r['wall']:.1f} s)",
                  flush=True)
            print(f"compliant K={K:g} rtol={rtol:g}: " + _contacts_line(
                result["compliant"][f"K={K:g} rtol={rtol:g}"]), flush=True)

    # how far the regularised friction's creep (where the source's law can stick) moves
    # the results: friction_v1 from the default down by 100, and no friction at all
    result["regularisation"] = {}
    for (v0, v1), mu in [*((r, None) for r in REGULARISATIONS), (REGULARISATIONS[0], 0.0)]:
        extra = {} if mu is None else {"friction_coefficient": mu}
        r = compliant_run(1e10, 1e-8, T, friction_v0=v0, friction_v1=v1, **extra)
        key = f"v0={v0:g} v1={v1:g}" + ("" if mu is None else f" mu={mu:g}")
        result["regularisation"][key] = {
            "crank_angle_end": float(r["q"][-1, 0]), "energy_end": _energy(r),
            "crank_rate_end": float(r["u"][-1, 0])}
        print(f"regularisation {key}: crank {r['q'][-1, 0]:.5f} rad, energy "
              f"{_energy(r):.5f} J", flush=True)
    reg = list(result["regularisation"].values())
    case, narrower, frictionless = reg[0], reg[1:len(REGULARISATIONS)], reg[-1]
    print("regularisation: the narrower laws move the crank angle by at most {:.1g} rad and "
          "the energy by {:.2g} J; friction as a whole (mu = 0) by {:.3f} rad and {:.3f} J".format(
              max(abs(n["crank_angle_end"] - case["crank_angle_end"]) for n in narrower),
              max(abs(n["energy_end"] - case["energy_end"]) for n in narrower),
              abs(frictionless["crank_angle_end"] - case["crank_angle_end"]),
              abs(frictionless["energy_end"] - case["energy_end"])), flush=True)

    d = mo.FLGData()
    free_end = 0.0024          # before the first contact (about 2.69 ms)
    result["moreau_free_flight_error"] = {
        f"h={h:g}": mo.free_flight_error(d, h, free_end) for h in steps}
    mruns = {}
    for h in steps:
        r = moreau_run(h, T)
        mruns[h] = r
        result["moreau"][f"h={h:g}"] = {
            "crank_angle_end": float(r["q"][-1, 0]), "crank_rate_end": float(r["u"][-1, 0]),
            "energy_end": _energy(r),
            "slider_angle_end": float(r["q"][-1, 2]), "first_contact": first_contact(r),
            "wall_s": r["wall"], **contact_summary(r)}
        print(f"Moreau h={h:g}: crank {r['q'][-1, 0]:.5f} rad, {r['u'][-1, 0]:.4f} rad/s, "
              f"energy {_energy(r):.5f} J; largest free-flight angle error "
              f"{result['moreau_free_flight_error'][f'h={h:g}']:.2g} rad ({r['wall']:.1f} s)",
              flush=True)
        print(f"Moreau h={h:g}: " + _contacts_line(result["moreau"][f"h={h:g}"]), flush=True)
    h1, h2 = steps[-2], steps[-1]
    ratio = h1 / h2
    extrap = {}
    for key in ("crank_angle_end", "crank_rate_end", "energy_end"):
        a, b = (result["moreau"][f"h={h:g}"][key] for h in (h1, h2))
        extrap[key] = float(b + (b - a) / (ratio - 1.0))
        extrap[key + "_error_at_finest"] = float(abs(b - extrap[key]))
    result["moreau_extrapolated"] = extrap
    print("Moreau extrapolated from h={:g} and {:g}: crank {:.5f} rad (+-{:.3f}), {:.4f} "
          "rad/s (+-{:.2f}), energy {:.5f} J (+-{:.3f})".format(
              h1, h2, *(extrap[k + e] for k in ("crank_angle_end", "crank_rate_end",
                                                 "energy_end")
                        for e in ("", "_error_at_finest"))), flush=True)
    _print_agreement(result, T)
    (args.out / "flores_benchmark.json").write_text(json.dumps(result, indent=2))
    _figures(args.out, runs[(1e10, 1e-10)], mruns[steps[-1]], steps[-1])
    print(f"wrote {args.out / 'flores_benchmark.json'} and the figures")
    return 0


def _contacts_line(summary: dict) -> str:
    """A run's first corner contact (ms, the corners touching then), the bottom pair's
    first contact and, for a compliant run, how long its first impact lasts (us)."""
    firsts = {n: c["first"] for n, c in summary["corners"].items() if c["first"] is not None}
    if not firsts:
        return "no corner contact"
    t1 = min(firsts.values())
    at_once = [n for n, t in firsts.items() if t == t1]
    bottom = [firsts[n] for n in ("rear_bottom", "front_bottom") if n in firsts]
    text = f"first contact {1e3 * t1:.2f} ms ({', '.join(at_once)})"
    if bottom:
        text += f", bottom pair first at {1e3 * min(bottom):.1f} ms"
    if "first_impact_duration" in summary:
        text += f", first impact lasts {1e6 * summary['first_impact_duration']:.0f} us"
    return text


def _print_agreement(result: dict, duration: float) -> None:
    """The energy both models lose over the run and how far each compliant run lies from
    the Moreau scheme's extrapolation, and each Moreau step's distance to it."""
    e0, ex = result["energy_start"], result["moreau_extrapolated"]
    for key, m in result["moreau"].items():
        d_q = m["crank_angle_end"] - ex["crank_angle_end"]
        d_u = m["crank_rate_end"] - ex["crank_rate_end"]
        print(f"Moreau {key} against the extrapolation: crank {d_q:+.3f} rad, {d_u:+.2f} "
              f"rad/s ({100 * d_u / ex['crank_rate_end']:+.1f} %)")
    lost = [e0 - c["energy_end"] for c in result["compliant"].values()]
    print(f"energy lost over {duration:g} s: Moreau extrapolated {e0 - ex['energy_end']:.2f} J "
          f"({100 * (e0 - ex['energy_end']) / e0:.1f} %), compliant runs {min(lost):.3f} to "
          f"{max(lost):.3f} J")
    d_q = max(abs(c["crank_angle_end"] - ex["crank_angle_end"])
              for c in result["compliant"].values())
    d_e = max(abs(c["energy_end"] - ex["energy_end"]) for c in result["compliant"].values())
    print(f"compliant runs against the Moreau extrapolation: crank angle within {d_q:.3f} rad "
          f"({100 * d_q / abs(ex['crank_angle_end']):.2f} %), energy within "
          f"{100 * d_e / ex['energy_end']:.1f} %")


def _figures(out: Path, ours, theirs, h):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.2))
    ax.plot(ours["t"], ours["q"][:, 0] / (2 * math.pi), label="compliant (K = 1e10 N/m^1.5)")
    ax.plot(theirs["t"], theirs["q"][:, 0] / (2 * math.pi), "--",
            label=f"Moreau, rigid (h = {h:g} s)")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("crank revolutions")
    ax.legend(loc="upper left")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "flores_crank.png", dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(4, 1, figsize=(7, 7), sharex=True)
    for k, (ax, name) in enumerate(zip(axes, CORNER_NAMES)):
        ax.plot(ours["t"], ours["offsets"][:, k], lw=0.8, label="compliant")
        ax.plot(theirs["t"], theirs["offsets"][:, k], "--", lw=0.8, label="Moreau")
        ax.set_ylabel(name.replace("_", " ") + "\n(y - y0) / c", fontsize=8)
        ax.set_ylim(-1.2, 1.2)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="lower right", fontsize=8)
    axes[-1].set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(out / "flores_corners.png", dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 2.8))
    for k in range(len(CORNER_NAMES)):
        for run, dy, colour in ((ours, 0.15, "C0"), (theirs, -0.15, "C1")):
            on = run["contact"][:, k]
            ax.plot(run["t"][on], np.full(on.sum(), k + dy), "|", color=colour, ms=6)
    ax.set_yticks(range(4), [n.replace("_", " ") for n in CORNER_NAMES])
    ax.set_xlabel("t (s)")
    ax.set_title("corners in contact: compliant (upper tick), Moreau (lower tick)",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "flores_contacts.png", dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
