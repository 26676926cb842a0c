"""Friction in the clearance joints: the paper's slider-crank and the slider-crank
with both coupler joints loose, at several coefficients of friction.

For each case and mu (Ambrosio's modified Coulomb law, the thresholds' defaults; mu = 0 is
the frictionless joint), one run of `revolutions` drive revolutions at the default rtol on
the generated model, and over the last revolution: the peak of the monitored force (the
crank pivot's reaction), the RMS drive moment, the work of the drive and of friction, and
per clearance joint the fraction of the revolution in contact (whether the journal follows
the bearing's wall) and the number of contact onsets. Prints a markdown table (what
docs/friction.md quotes) and draws the journal orbits of the last revolution.

    python -m validation.friction_study [--revolutions 4] [--mu 0,0.01,0.05,0.1]
        [--law ambrosio] [--clearance C] [--figure docs/figures/friction_orbits.png]

`--clearance` (m) sets every clearance joint's radial clearance (default: the cases', 0.01 mm).

With `--sensitivities`, instead: the paper's sensitivities of |F12| (Figs. 4-6, DDM, the
paper's parameters) of the SliderCrank at each mu (default 0, 0.01, 0.1), a markdown table
of each parameter's max |normalized sensitivity| and max |d|F12|/db| over the last
revolution and their change against mu = 0, and a figure of the normalized sensitivities
with the coefficients overlaid, one panel per parameter:

    python -m validation.friction_study --sensitivities
        --figure docs/figures/friction_sensitivities.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mbs_clearance import simulate
from mbs_clearance.model import cases

CASES = ("paper_slider_crank", "slider_crank_two_clearances")


def _window(traj, period, rev):
    """Indices of the recorded steps in revolution `rev` (1-based)."""
    return np.flatnonzero((traj.t >= (rev - 1) * period - 1e-15)
                          & (traj.t <= rev * period + 1e-15))


def measures(traj, period, rev):
    """The last revolution's measures of one run (a dict)."""
    idx = _window(traj, period, rev)
    t = traj.t[idx]
    dt = np.diff(t)
    moment = traj.crank_moment[idx]
    rms = float(np.sqrt(np.sum(0.5 * (moment[1:] ** 2 + moment[:-1] ** 2) * dt) / period))
    # the contact mode of a step is the memory at its start (the integrator lands on each
    # onset and separation)
    phase = traj.contact_phase[idx]
    follow = [float(np.sum(dt * phase[:-1, j]) / period) for j in range(phase.shape[1])]
    onsets = [int(np.sum(np.diff(phase[:, j].astype(int)) == 1))
              for j in range(phase.shape[1])]
    fw = 0.0 if traj.friction_work is None else float(
        traj.friction_work[idx[-1]] - traj.friction_work[idx[0]])
    return {"peak": float(traj.peaks[rev - 1]), "rms_moment": rms,
            "drive_work": float(traj.crank_work[idx[-1]] - traj.crank_work[idx[0]]),
            "friction_work": fw, "in_contact": follow, "onsets": onsets,
            "nfev": int(traj.stats["nfev"])}


#: per case, the overrides that set its clearances to c (m)
_CLEARANCE = {
    "paper_slider_crank": lambda c: {"journal_radius": 0.010 - c},
    "slider_crank_two_clearances": lambda c: {"crank_coupler_clearance": c,
                                              "coupler_slider_clearance": c},
}


def study(mus, revolutions: int, law: str, clearance: float | None = None,
          case_names=CASES):
    """{case: [(mu, measures, trajectory)]}."""
    out = {}
    for case in case_names:
        rows = []
        for mu in mus:
            over = {} if mu == 0.0 else {"friction_law": law, "friction_coefficient": mu}
            if clearance is not None:
                over.update(_CLEARANCE[case](clearance))
            lk = getattr(cases, case)(**over)
            traj = simulate(lk, revolutions)
            rows.append((mu, measures(traj, lk.period, revolutions), traj))
        out[case] = rows
    return out


def table(results, revolutions: int) -> str:
    lines = [f"| case | mu | rev-{revolutions} peak (N) | change | RMS drive moment (N m) | "
             "drive work (J) | friction work (J) | in contact (fraction of the revolution) "
             "| contact onsets | nfev |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for case, rows in results.items():
        p0 = rows[0][1]["peak"]
        for mu, m, traj in rows:
            joints = traj.joints
            contact = ", ".join(f"{j} {f:.3f}" for j, f in zip(joints, m["in_contact"]))
            onsets = ", ".join(f"{j} {k}" for j, k in zip(joints, m["onsets"]))
            lines.append(f"| {case} | {mu:g} | {m['peak']:.1f} | {m['peak'] / p0 - 1:+.2%} | "
                         f"{m['rms_moment']:.4f} | {m['drive_work']:.4f} | "
                         f"{m['friction_work']:.4f} | {contact} | {onsets} | {m['nfev']} |")
    return "\n".join(lines)


def figure(results, revolutions: int, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [(case, k, joint) for case, rows in results.items()
              for k, joint in enumerate(rows[0][2].joints)]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 4.4))
    theta = np.linspace(0, 2 * np.pi, 400)
    for ax, (case, k, joint) in zip(np.atleast_1d(axes), panels):
        for mu, _, traj in results[case]:
            lk = traj.mechanism
            c = lk.clearance_joints[k].clearance
            idx = _window(traj, lk.period, revolutions)
            e = traj.eccentricity[idx, k, :] / c
            ax.plot(e[:, 0], e[:, 1], lw=0.8, label=f"mu = {mu:g}")
        ax.plot(np.cos(theta), np.sin(theta), "k--", lw=0.6)
        ax.set_aspect("equal")
        ax.set_title(f"{case}\n{joint}", fontsize=9)
        ax.set_xlabel("e_x / clearance")
        ax.set_ylabel("e_y / clearance")
    np.atleast_1d(axes)[0].legend(fontsize=8, loc="center")
    fig.suptitle(f"journal centre relative to the bearing centre, revolution {revolutions}",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def sensitivity_study(mus, revolutions: int = 4, law: str = "ambrosio"):
    """[(mu, Sensitivities)] of the paper's SliderCrank, DDM, the paper's parameters."""
    from mbs_clearance import SliderCrank, sensitivities
    from mbs_clearance.analysis.sensitivity import DEFAULT_PARAMETERS

    out = []
    for mu in mus:
        mech = SliderCrank() if mu == 0.0 else SliderCrank(friction_law=law,
                                                          friction_coefficient=mu)
        out.append((mu, sensitivities(mech, DEFAULT_PARAMETERS, revolutions, method="ddm")))
    return out


def sensitivity_measures(results) -> list[dict]:
    """Per parameter: max |S| (Eq. 15) and max |d|F12|/db| over the last revolution at each
    mu, their relative changes against the first mu (the frictionless run), and whether
    every run was judged periodic. Rows in the paper's order."""
    rows = []
    mu0, s0 = results[0]
    for k, name in enumerate(s0.parameters):
        row = {"parameter": name, "mu": [], "max_s": [], "max_d": [], "periodic": []}
        for mu, s in results:
            mask = s.revolution_mask(s.trajectory.revolutions)
            row["mu"].append(mu)
            row["max_s"].append(float(np.abs(s.normalized[mask, k]).max()))
            row["max_d"].append(float(np.abs(s.base_force_magnitude[mask, k]).max()))
            row["periodic"].append(s.periodic)
        row["change_s"] = [m / row["max_s"][0] - 1 for m in row["max_s"]]
        row["change_d"] = [m / row["max_d"][0] - 1 for m in row["max_d"]]
        rows.append(row)
    return rows


def sensitivity_table(rows) -> str:
    """Markdown: per parameter, max |S| and max |d|F12|/db| at each mu and their change."""
    mus = rows[0]["mu"]
    head = ["parameter"] + [f"max \\|S\\| mu={m:g}" for m in mus] + \
        [f"max \\|dF/db\\| mu={m:g}" for m in mus]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [r["parameter"], f"{r['max_s'][0]:.4g}"]
        cells += [f"{v:.4g} ({c:+.1%})" for v, c in zip(r["max_s"][1:], r["change_s"][1:])]
        cells.append(f"{r['max_d'][0]:.4g}")
        cells += [f"{v:.4g} ({c:+.1%})" for v, c in zip(r["max_d"][1:], r["change_d"][1:])]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def sensitivity_figure(results, path: str) -> None:
    """Figs. 4-6 with friction: the normalized sensitivity of |F12| (Eq. 15) over the last
    revolution, one panel per parameter (grouped as the paper's figures), the coefficients
    of friction overlaid."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mbs_clearance.plotting import SENSITIVITY_FIGURES

    panels = [(title.split(":")[0], name) for title, group in SENSITIVITY_FIGURES.values()
              for name in group if name in results[0][1].parameters]
    ncol = 4
    nrow = -(-len(panels) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.0 * ncol, 3.0 * nrow), squeeze=False)
    styles = ["-", "--", ":", "-."]
    for ax, (fig_name, name) in zip(axes.flat, panels):
        for i, (mu, s) in enumerate(results):
            rev = s.trajectory.revolutions
            mask = s.revolution_mask(rev)
            ang = np.degrees(s.trajectory.crank_angle[mask]) - 360.0 * (rev - 1)
            ax.plot(ang, s.normalized[mask, s.column(name)], styles[i % len(styles)],
                    color=f"C{i}", lw=0.9, label=f"mu = {mu:g}")
        ax.set_title(f"{fig_name}: {name}", fontsize=9)
        ax.set_xlabel("crank angle in revolution (deg)", fontsize=8)
        ax.set_ylabel("normalized sensitivity (-)", fontsize=8)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=8, loc="upper right")
    rev = results[0][1].trajectory.revolutions
    fig.suptitle("Sensitivities of |F12| (Eq. 15, DDM) with friction in the joint "
                 f"(Ambrosio's law), revolution {rev}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--revolutions", type=int, default=4)
    parser.add_argument("--mu", default=None,
                        help="coefficients of friction (default 0,0.01,0.05,0.1; with "
                             "--sensitivities 0,0.01,0.1)")
    parser.add_argument("--law", default="ambrosio", choices=("ambrosio", "coulomb"))
    parser.add_argument("--clearance", type=float, default=None,
                        help="radial clearance of every joint in m (default: the cases')")
    parser.add_argument("--figure", default=None, help="path of the figure (PNG)")
    parser.add_argument("--sensitivities", action="store_true",
                        help="the sensitivities of Figs. 4-6 with friction instead")
    args = parser.parse_args(argv)
    mu_text = args.mu or ("0,0.01,0.1" if args.sensitivities else "0,0.01,0.05,0.1")
    mus = [float(v) for v in mu_text.split(",")]
    if args.figure:            # its folder, before the runs (the documented docs/figures/...)
        Path(args.figure).parent.mkdir(parents=True, exist_ok=True)
    if args.sensitivities:
        if mus[0] != 0.0:
            parser.error("--sensitivities compares against the frictionless run: the first "
                         "--mu must be 0")
        sens = sensitivity_study(mus, args.revolutions, args.law)
        print(sensitivity_table(sensitivity_measures(sens)))
        for mu, s in sens:
            print(f"mu = {mu:g}: {s.periodicity_note}")
        if args.figure:
            sensitivity_figure(sens, args.figure)
            print(f"wrote {args.figure}")
        return
    results = study(mus, args.revolutions, args.law, args.clearance)
    print(table(results, args.revolutions))
    if args.figure:
        figure(results, args.revolutions, args.figure)
        print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
