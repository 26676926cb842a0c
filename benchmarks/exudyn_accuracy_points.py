"""Exudyn's requested accuracy off the default: ``simulate(..., backend="exudyn",
accuracy=a)`` against the reduced model's converged value (rtol 1e-12).

Per point and revolution: Exudyn's extrapolated peak, its bar (``stats["peak_errors"]``;
the onsets' share of it, ``stats["onset_errors"]``, in the last column),
the true error against the reference, whether the bar covers it, the observed order, the
steps run and the time of each run (where the time goes). The points: the paper case at
2000 rpm, at c = 0.05 mm and at the GA box's grazing design (L2 = 4.5 cm, L3 = 12.5 cm:
its re-contact in revolution 1 is a grazing onset, `solve.diagnostics.GRAZING_ONSET`), and
the four-bar at 5 rpm, c = 0.05 mm and restitution 0.5 (one revolution).

    python -m benchmarks.exudyn_accuracy_points [--case NAME] [--points LABEL ...]
                                                [--accuracy 1e-4] [--revolutions 2]
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import numpy as np

from mbs_clearance import simulate
from mbs_clearance._warnings import AccuracyWarning
from mbs_clearance.model import cases
from mbs_clearance.solve.accuracy import revolution_peaks

RPM = 2.0 * math.pi / 60.0

#: label -> (case, overrides, revolutions: None = --revolutions)
POINTS = {
    "2000 rpm": ("paper_slider_crank", {"crank_speed": 2000 * RPM}, None),
    "c = 0.05 mm": ("paper_slider_crank", {"journal_radius": 0.01 - 5e-5}, None),
    "grazing design": (
        "paper_slider_crank", {"crank_length": 0.045, "coupler_length": 0.125}, None),
    "four-bar 5 rpm": ("four_bar", {"crank_speed": 5 * RPM}, 1),
    "four-bar c = 0.05 mm": ("four_bar", {"clearance": 5e-5}, 1),
    "four-bar e = 0.5": ("four_bar", {"restitution": 0.5}, 1),
}

#: the reference's rtol and step limit (the four-bar's exceed the default)
REFERENCE_RTOL = 1e-12
REFERENCE_MAX_STEPS = 50_000_000


def grazing_onsets(linkage, revolutions: int) -> int:
    """Grazing onsets of the reduced model's run at rtol 1e-10 (``stats``)."""
    return int(simulate(linkage, revolutions, rtol=1e-10).stats.get("grazing_onsets", 0))


def measure(label: str, accuracy: float, revolutions: int) -> dict:
    """One point: the reference, Exudyn at `accuracy`, its bar and true error."""
    case, overrides, revs = POINTS[label]
    revs = revolutions if revs is None else revs
    linkage = cases.CASES[case](**overrides)
    t0 = time.perf_counter()
    ref = revolution_peaks(simulate(linkage, revs, rtol=REFERENCE_RTOL,
                                    max_steps=REFERENCE_MAX_STEPS))
    ref_seconds = time.perf_counter() - t0
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)    # recorded in stats["accuracy_ok"]
        tr = simulate(linkage, revs, backend="exudyn", accuracy=accuracy)
    seconds = time.perf_counter() - t0
    st = tr.stats
    value = np.asarray(tr.peaks, dtype=float)
    return {"point": label, "revolutions": revs, "reference": ref, "value": value,
            "bar": np.asarray(st["peak_errors"]) / np.abs(value),
            "onset": (np.full(revs, np.nan) if st["onset_errors"] is None
                      else np.asarray(st["onset_errors"]) / np.abs(value)),
            "onset_seconds": st["onset_seconds"], "onset_note": st["onset_note"],
            "error": value / ref - 1.0, "order": np.asarray(st["observed_order"]),
            "steps": st["accuracy_steps"], "run_seconds": st.get("accuracy_run_seconds", []),
            "peaks": np.asarray(st["accuracy_peaks"]), "ok": st["accuracy_ok"],
            "seconds": seconds, "reference_seconds": ref_seconds,
            "grazing": grazing_onsets(linkage, revs)}


def report(r: dict, accuracy: float) -> str:
    """One line on the point's runs, then one table row per revolution."""
    lines = [f"{r['point']}: Exudyn {r['seconds']:.0f} s, {len(r['steps'])} runs at steps "
             + ", ".join(f"{h * 1e6:.3g}" for h in r["steps"]) + " us taking "
             + ", ".join(f"{s:.0f}" for s in r["run_seconds"])
             + f" s, the onsets' share {r['onset_seconds']:.0f} s; reference "
             f"{r['reference_seconds']:.1f} s; accuracy_ok {r['ok']}; grazing onsets "
             f"{r['grazing']}" + (f"; the onsets' share {r['onset_note']}"
                                  if r["onset_note"] else "")]
    for k in range(r["revolutions"]):
        err, bar = r["error"][k], r["bar"][k]
        order = "-" if not np.isfinite(r["order"][k]) else f"{r['order'][k]:.2f}"
        lines.append(f"| {r['point']} | {k + 1} | {r['value'][k]:.4f} | "
                     f"{r['reference'][k]:.4f} | {err:+.2e} | {bar:.2e} | "
                     f"{'yes' if abs(err) <= bar else 'no'} | "
                     f"{'yes' if abs(err) <= accuracy else 'no'} | {order} | "
                     f"{_cell(r['onset'][k])} |")
        rel = r["peaks"][:, k] / r["reference"][k] - 1.0
        lines.append(f"  {r['point']}, revolution {k + 1}, each run's peak against the reference: "
                     + ", ".join(f"{x:+.2e}" for x in rel))
    return "\n".join(lines)


def _cell(share: float) -> str:
    return f"{share:.2e}" if np.isfinite(share) else "-"


HEAD = ("| point | revolution | Exudyn (N) | reference (N) | true error | bar | bar covers it "
        "| within the request | observed order | onsets' share of the bar |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--accuracy", type=float, default=1e-4)
    ap.add_argument("--revolutions", type=int, default=2,
                    help="revolutions of the slider-crank points (the four-bar's: 1)")
    ap.add_argument("--points", nargs="*", choices=list(POINTS),
                    help="the points (default: every point of --case, else all)")
    ap.add_argument("--case", choices=sorted({c for c, _, _ in POINTS.values()}))
    args = ap.parse_args(argv)
    labels = args.points or [k for k, (c, _, _) in POINTS.items()
                             if args.case in (None, c)]
    print(HEAD, flush=True)
    for label in labels:
        print(report(measure(label, args.accuracy, args.revolutions), args.accuracy),
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
