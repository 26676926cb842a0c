"""Numerical stress tests: where do the models break, and do they say so clearly?

A sweep over clearance (0.001-1 mm), crank speed (100-10000 rpm), restitution (0.05-1),
contact stiffness (x0.01-x100), initial crank angle, zero gravity, 100-revolution runs, the
journal starting against the wall and grazing contacts. Every case checks:

- the run succeeds, or fails with a clear error that says what to change (RuntimeError or
  ValueError from our code; a NaN or a traceback from deep inside is a failure);
- every output is finite;
- no missed contact: no free-flight sample inside the wall, and none inside any free-flight
  step either: every free-flight step is re-taken from its start to 19 interior times with
  the same Runge-Kutta map, and the penetration there must stay <= 0 (comparing runs with
  smaller steps is no check here: chaotic cases diverge);
- with e = 1, the energy balance closes (crank work = change of mechanical energy).

A case that passes these checks but whose run misses its own requested accuracy (the
reduced model's error estimate of the peaks above the request, or a rattling contact) is
"flagged", not "pass": its invariants hold, its peaks are not accurate to the request.

    python -m validation.stress [--quick] [--backend reduced exudyn] [--json out.json]
    mbs-clearance stress [--quick]
"""

from __future__ import annotations

import json
import math
import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mbs_clearance import SliderCrank, simulate
from mbs_clearance._warnings import AccuracyWarning
from mbs_clearance.generate.energy import mechanical_energy
from mbs_clearance.numerics.integrator import METHODS
from mbs_clearance.solve import reduced

RPM = 2 * math.pi / 60

#: Exudyn runs longer than this many fixed steps are skipped in the sweep (~1 min each)
MAX_EXUDYN_STEPS = 60_000


@dataclass
class StressCase:
    """One configuration of the sweep."""

    name: str
    mech: SliderCrank
    revolutions: int = 4
    options: dict[str, Any] = field(default_factory=dict)


def stress_cases(quick: bool = False) -> list[StressCase]:
    """The sweep; `quick` keeps one case per axis and shorter runs (for tests and CI)."""
    base = SliderCrank()
    k0 = base.stiffness
    cases = [StressCase("paper case", base)]
    for c_mm in (0.001, 0.1, 1.0):
        cases.append(StressCase(f"clearance {c_mm:g} mm",
                                base.replace(journal_radius=0.01 - c_mm * 1e-3)))
    for rpm in (100, 1000, 10000):
        cases.append(StressCase(f"speed {rpm} rpm", base.replace(crank_speed=rpm * RPM),
                                revolutions=2 if rpm <= 100 else 4))
    for e in (0.05, 0.3, 1.0):
        cases.append(StressCase(f"restitution {e:g}", base.replace(restitution=e)))
    for f in (0.01, 100.0):
        cases.append(StressCase(f"stiffness x{f:g}", base.replace(contact_stiffness=f * k0)))
    for deg in (90, 180, 270):
        cases.append(StressCase(f"initial crank angle {deg} deg",
                                base.replace(initial_crank_angle=math.radians(deg))))
    cases.append(StressCase("zero gravity", base.replace(gravity=0.0)))
    cases.append(StressCase("100 revolutions", base, revolutions=100))
    for off in (1.0, -1.0):
        cases.append(StressCase(f"journal starts against the wall ({off:+g} c)", base,
                                options={"initial_offset": off}))
    cases.append(StressCase("grazing: 100 rpm, 1 mm, e = 1, journal on the wall",
                            base.replace(crank_speed=100 * RPM, journal_radius=0.009,
                                         restitution=1.0),
                            revolutions=1, options={"initial_offset": 1.0}))
    for model in ("hunt_crossley", "flores"):
        cases.append(StressCase(f"{model} law, restitution 0.05",
                                base.replace(contact_model=model, restitution=0.05)))
    cases.append(StressCase("clearance 0.5 mm, e = 1 (chaotic, energy)",
                            base.replace(journal_radius=0.0095, restitution=1.0)))
    if quick:
        keep = ("paper case", "clearance 1 mm", "speed 10000 rpm", "restitution 0.05",
                "restitution 1", "stiffness x100", "journal starts against the wall (+1 c)")
        cases = [c for c in cases if c.name in keep]
        for c in cases:
            c.revolutions = min(c.revolutions, 2)
    return cases


def _energy_error(case: StressCase) -> float:
    """max |W - (E - E0)| / max |W| with e = 1 (rtol 1e-10)."""
    ts, ys, ms, *_, p = reduced.run(case.mech, case.revolutions, rtol=1e-10, **case.options)
    q = p.copy()
    energy = np.empty(len(ts))
    energy_of = mechanical_energy(reduced.linkage_of(case.mech))
    mem = reduced.MEM_START
    for i in range(len(ts)):
        q[mem:mem + 2] = ms[i]
        energy[i] = energy_of(ts[i], ys[i], q)
    work = ys[:, -1]
    return float(np.max(np.abs(work - (energy - energy[0]))) / max(np.max(np.abs(work)), 1e-12))


def _step_excursion(ts, ys, ms, p, coefficients, n_sub, mode):
    """Re-taken steps of one contact mode (0: free flight, 1: contact) at n_sub - 1 interior
    times: the largest excursion to the wrong side of the wall, in clearances (delta / c in
    free flight, -delta / c in contact; > 0 means a missed contact or separation), with the
    compiled model's step map (p: its parameters, as reduced.run returns them)."""
    from mbs_clearance.core.integrate import model_record, step_states

    # the layout read once: each module attribute looks the model up again
    model, mem, clearance = reduced.MODEL, reduced.MEM_START, reduced.P_CLEARANCE
    record = model_record(model.ffi, model.lib)
    q = p.copy()
    worst = -np.inf
    fractions = np.arange(1, n_sub) / n_sub
    for k in range(ts.shape[0] - 1):
        if (ms[k, 0] > 0.5) != (mode == 1):
            continue
        q[mem] = ms[k, 0]
        q[mem + 1] = ms[k, 1]
        hs = (ts[k + 1] - ts[k]) * fractions
        states, _ = step_states(record, ts[k], ys[k], q, hs, coefficients, 0)
        for h, y_new in zip(hs, states):
            # the switching function: delta in free flight, -delta in contact
            d = model.event(ts[k] + h, y_new, q, 0)[0] / q[clearance]
            worst = max(worst, d)
    return worst


def step_excursions(case: StressCase, n_sub: int = 20) -> tuple[float, float]:
    """Largest excursion (in clearances) to the wrong side of the wall inside any free-flight
    step (a missed contact) and inside any contact step (a missed separation: the journal
    leaves and comes back within one step, keeping a stale impact velocity)."""
    ts, ys, ms, *_, p = reduced.run(case.mech, case.revolutions, **case.options)
    tab = METHODS[case.options.get("method", "dopri5")]   # re-take with the run's method
    return tuple(float(_step_excursion(ts, ys, ms, p, tab.arrays(), n_sub, mode))
                 for mode in (0, 1))


def run_case(case: StressCase, backend: str = "reduced") -> dict[str, Any]:
    """Run one case and check the invariants; returns a result row. A stress case may well
    miss the stated accuracy (rattling, grazing): its AccuracyWarnings are the row's notes,
    not failures of the invariants checked here."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", AccuracyWarning)
        row = _check_case(case, backend)
    for w in caught:
        if issubclass(w.category, AccuracyWarning):
            if str(w.message) not in row.setdefault("notes", []):
                row["notes"].append(str(w.message))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return row


def _check_case(case: StressCase, backend: str) -> dict[str, Any]:
    row: dict[str, Any] = {"case": case.name, "backend": backend, "status": "pass",
                           "reasons": [], "revolutions": case.revolutions}
    t0 = time.perf_counter()
    options = dict(case.options) if backend == "reduced" else {}
    if backend != "reduced" and case.options:
        row.update(status="skipped", reasons=["option only in the reduced model"])
        return row
    if backend == "exudyn":
        from mbs_clearance.backends.exudyn_model import DEFAULT_STEP_SIZE

        steps = case.revolutions * case.mech.period / DEFAULT_STEP_SIZE
        if steps > MAX_EXUDYN_STEPS:
            row.update(status="skipped", reasons=[
                f"{steps:.2g} fixed steps of {DEFAULT_STEP_SIZE:g} s: too long for a sweep"])
            return row
    try:
        traj = simulate(case.mech, case.revolutions, backend=backend, **options)
    except (RuntimeError, ValueError) as exc:
        row.update(status="clear error", reasons=[str(exc)],
                   seconds=time.perf_counter() - t0)
        return row
    row["seconds"] = time.perf_counter() - t0
    bad = [name for name in ("base_force", "crank_moment", "contact_force", "penetration",
                             "eccentricity", "slider_acceleration")
           if not np.all(np.isfinite(getattr(traj, name)))]
    if bad:
        row["reasons"].append(f"non-finite outputs: {bad}")
    free = traj.contact_phase == 0
    worst = float(traj.penetration[free].max(initial=-np.inf)) / case.mech.clearance
    row["max_free_penetration_over_c"] = worst
    tolerance = 1e-9 if backend == "reduced" else 0.05
    if worst > tolerance:
        row["reasons"].append(f"free-flight sample inside the wall ({worst:.2g} c)")
    row["peak_last_revolution"] = traj.max_base_force(case.revolutions)
    row["contact_switches"] = int(np.count_nonzero(np.diff(traj.contact_phase)))
    if backend == "reduced":
        inside, outside = step_excursions(case)
        row["max_inside_free_steps_over_c"] = inside
        row["max_outside_contact_steps_over_c"] = outside
        if inside > 1e-9:
            row["reasons"].append(f"the journal enters the wall inside a free-flight step "
                                  f"({inside:.2g} c): a missed contact")
        if outside > 1e-9:
            row["reasons"].append(f"the journal leaves the wall inside a contact step "
                                  f"({outside:.2g} c): a missed separation")
        if case.mech.restitution == 1.0:
            err = _energy_error(case)
            row["energy_error"] = err
            if not err < 1e-6:
                row["reasons"].append(f"energy balance off by {err:.2g} of the crank work")
    if row["reasons"]:
        row["status"] = "fail"
    elif traj.stats.get("accuracy_ok") is False:
        row["status"] = "flagged"
        row["accuracy"] = traj.stats.get("accuracy")
        row["error_estimate"] = traj.stats.get("error_estimate")
    return row


def run_sweep(cases: list[StressCase], backends=("reduced",), progress: bool = True):
    """Run every case on every backend (with a progress bar)."""
    from tqdm import tqdm

    jobs = [(c, b) for b in backends for c in cases]
    rows = []
    for case, backend in tqdm(jobs, desc="stress", disable=not progress):
        rows.append(run_case(case, backend))
    return rows


def summary(rows) -> dict[str, Any]:
    """Counts of cases run, passed, flagged (invariants hold, accuracy not met), clear
    errors, failures (with reasons)."""
    counts = {s: sum(r["status"] == s for r in rows)
              for s in ("pass", "flagged", "clear error", "fail", "skipped")}
    return {"cases": len(rows), **counts,
            "failures": [(r["case"], r["backend"], r["reasons"]) for r in rows
                         if r["status"] == "fail"]}


def backend_differences(rows) -> list[dict[str, Any]]:
    """Per case run on both backends: last-revolution peaks and their relative difference."""
    by_case: dict[str, dict[str, float]] = {}
    for r in rows:
        if "peak_last_revolution" in r:
            by_case.setdefault(r["case"], {})[r["backend"]] = r["peak_last_revolution"]
    return [{"case": case, "reduced": p["reduced"], "exudyn": p["exudyn"],
             "difference_percent": 100 * (p["exudyn"] / p["reduced"] - 1)}
            for case, p in by_case.items() if {"reduced", "exudyn"} <= set(p)]


def markdown_table(rows) -> str:
    """The results as a markdown table."""
    lines = ["| case | backend | status | s | last-rev. peak \\|F12\\| (N) | switches "
             "| energy error | notes |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        peak = r.get("peak_last_revolution")
        lines.append(
            f"| {r['case']} | {r['backend']} | {r['status']} | {r.get('seconds', 0):.2f} | "
            f"{'' if peak is None else f'{peak:.1f}'} | {r.get('contact_switches', '')} | "
            f"{'' if 'energy_error' not in r else format(r['energy_error'], '.1e')} | "
            f"{'; '.join(r['reasons'] + r.get('notes', []))[:160]} |")
    return "\n".join(lines)


def main(args) -> int:
    from mbs_clearance._io import RUN_KEY, atomic_file, check_output_file, run_stamp

    if args.json:
        check_output_file(args.json, "--json", args.force, suffixes=(".json",))
    rows = run_sweep(stress_cases(args.quick), tuple(args.backend), progress=True)
    print(markdown_table(rows))
    s = summary(rows)
    print(f"\n{s['cases']} runs: {s['pass']} passed, {s['flagged']} flagged (accuracy not "
          f"met), {s['clear error']} clear errors, {s['fail']} failed, {s['skipped']} skipped")
    diffs = backend_differences(rows)
    if diffs:
        print("\n| case | reduced peak (N) | exudyn peak (N) | difference |\n|---|---|---|---|")
        for d in diffs:
            print(f"| {d['case']} | {d['reduced']:.1f} | {d['exudyn']:.1f} | "
                  f"{d['difference_percent']:+.2f} % |")
    if args.json:
        with atomic_file(args.json) as tmp, open(tmp, "w") as fh:
            json.dump({RUN_KEY: run_stamp("stress"), "rows": rows, "summary": s}, fh,
                      indent=1, default=str)
    return 1 if s["fail"] else 0


def add_arguments(p):
    from pathlib import Path

    from mbs_clearance.cli import add_force_option

    p.add_argument("--quick", action="store_true", help="one case per axis, short runs")
    p.add_argument("--backend", nargs="+", default=["reduced"], choices=("reduced", "exudyn"),
                   help="backends to sweep (reduced, exudyn)")
    p.add_argument("--json", type=Path, help="write rows and summary to this JSON file")
    add_force_option(p)


if __name__ == "__main__":
    from .commands import stress

    stress.run_script()
