"""The report of a free linkage (no drive), `mbs-clearance report --case NAME` for such a
case: its description, its response over a time span (the monitored force per window, each
contact's penetration and force, and for a translational clearance joint its corners'
positions across the guide), and for the translational-clearance benchmark the comparison
with the nonsmooth reference (`validation.flores_benchmark`). The studies built on drive
revolutions (cross-check per revolution, sensitivities, Sobol indices, regime maps) need a
drive; the report says so instead of running them."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .report import numbered_titles

SECTIONS = ("description", "response", "benchmark", "environment")
TITLES = numbered_titles(SECTIONS, {
    "description": "The linkage",
    "response": "Response over time",
    "benchmark": "Against the nonsmooth reference (Moreau's time stepping)",
    "environment": "Environment",
}, ("environment",))

#: the benchmark case that gets the benchmark section
BENCHMARK_CASE = "flores_translational_slider_crank"


def settings(quick: bool, duration: float | None = None) -> dict[str, Any]:
    from mbs_clearance.model.cases import FLORES_DURATION

    return {"quick": quick, "duration": duration or FLORES_DURATION,
            "windows": 4, "moreau_steps": [2e-5, 1e-5] if quick else [1e-5, 5e-6, 2.5e-6]}


def section_description(linkage, out: Path, s: dict) -> dict:
    return {
        "name": linkage.name, "case": linkage.case, "overrides": dict(linkage.overrides or {}),
        "bodies": [{"name": b.name, "mass": b.mass, "inertia": b.inertia}
                   for b in linkage.bodies],
        "contacts": [{"name": j.name, "clearance": j.clearance, "stiffness": j.stiffness,
                      "restitution": j.restitution, "contact_model": j.contact_model,
                      "friction_law": j.friction_law,
                      "friction_coefficient": j.friction_coefficient}
                     for j in (*linkage.clearance_joints, *linkage.translational_joints)],
        "initial": {"coordinates": dict(linkage.start.coordinates),
                    "rates": dict(linkage.start.rates)},
        "gravity": linkage.gravity,
    }


def section_response(linkage, out: Path, s: dict) -> dict:
    from mbs_clearance import simulate

    T = s["duration"]
    traj = simulate(linkage, duration=T, window=T / s["windows"], rtol=1e-10)
    traj.save(out / "data" / "response.npz")
    pen = traj.penetration
    return {
        "duration": T, "window": T / s["windows"],
        "peaks": [float(p) for p in traj.peaks],
        "contacts": {j: {"max_penetration": float(pen[:, k].max()),
                         "max_force": float(traj.contact_force[:, k].max()),
                         "onsets": int(np.sum(np.diff((pen[:, k] > 0).astype(int)) > 0))}
                     for k, j in enumerate(traj.joints)},
        "end": {n: float(v[-1]) for n, v in traj.coordinates.items()},
        "end_rates": {n: float(v[-1]) for n, v in traj.rates.items()},
    }


def section_benchmark(linkage, out: Path, s: dict) -> dict:
    if linkage.case != BENCHMARK_CASE:
        return {"skipped": f"only for the case {BENCHMARK_CASE!r}"}
    from . import flores_benchmark as fb
    from . import moreau as mo

    T = s["duration"]
    K = linkage.translational_joints[0].stiffness
    ours = fb.compliant_run(K, 1e-10, T)
    moreau = {h: fb.moreau_run(h, T) for h in s["moreau_steps"]}
    h1, h2 = s["moreau_steps"][-2:]
    r = h1 / h2

    def extrapolated(f):
        a, b = f(moreau[h1]), f(moreau[h2])
        return float(b + (b - a) / (r - 1.0)), float(abs(b - a) / (r - 1.0))

    angle = extrapolated(lambda m: m["q"][-1, 0])
    energy = extrapolated(fb._energy)
    fb._figures(out / "figures", ours, moreau[h2], h2)
    np.savez(out / "data" / "benchmark.npz", t=ours["t"], q=ours["q"], u=ours["u"])
    d = mo.FLGData()
    return {
        "stiffness": K, "steps": list(s["moreau_steps"]),
        "compliant": {"crank_angle": float(ours["q"][-1, 0]), "energy": fb._energy(ours),
                      "first_contact": fb.first_contact(ours),
                      **fb.contact_summary(ours)},
        "moreau": {f"{h:g}": {"crank_angle": float(m["q"][-1, 0]),
                              "energy": fb._energy(m)} for h, m in moreau.items()},
        "moreau_extrapolated": {"crank_angle": angle[0], "crank_angle_bar": angle[1],
                                "energy": energy[0], "energy_bar": energy[1]},
        "moreau_first_contact": fb.first_contact(moreau[h2]),
        "energy_start": float(mo.energy(d, d.q0, d.u0)),
        "compliant_jammed_share": fb.contact_summary(ours)["jammed_share"],
    }


def draw_figures(out: Path, n: dict) -> dict[str, list[str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mbs_clearance import load_trajectory

    figs: dict[str, list[str]] = {k: [] for k in SECTIONS}
    traj = load_trajectory(out / "data" / "response.npz")
    fig, ax = plt.subplots(1, 2, figsize=(14, 4))
    ax[0].plot(traj.t, np.hypot(*traj.base_force.T), lw=0.7)
    ax[0].set(xlabel="t (s)", ylabel="monitored force (N)", title="monitored force")
    for k, name in enumerate(traj.joints):
        ax[1].plot(traj.t, traj.contact_force[:, k], lw=0.7, label=name)
    ax[1].set(xlabel="t (s)", ylabel="contact force (N)", title="contact forces")
    ax[1].legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(out / "figures" / "response.png", dpi=110)
    plt.close(fig)
    figs["response"].append("response.png")
    if "skipped" not in n["benchmark"]:
        figs["benchmark"] += ["flores_crank.png", "flores_corners.png", "flores_contacts.png"]
    return figs


TEMPLATE = """<!doctype html>
<html><head><meta charset="utf-8"><title>mbs-clearance report: {{ n.description.name }}</title>
<style>body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}
table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px;text-align:right}
th{background:#f3f3f3}img{max-width:100%}</style></head><body>
<h1>Report of the free linkage "{{ n.description.name }}"</h1>
<p>{% if n.description.case %}Named case <code>{{ n.description.case }}</code>.{% else %}A
description file.{% endif %} No drive: the linkage moves from its initial state for
{{ n.response.duration }} s. {% if quick %}<b>Quick report</b>.{% endif %} The studies
built on drive revolutions (the per-revolution Exudyn cross-check, sensitivities, Sobol
indices, regime maps) need a drive and are not part of this report.</p>

<h2>{{ titles.description }}</h2>
<table><tr><th>body</th><th>mass (kg)</th><th>inertia (kg m^2)</th></tr>
{% for b in n.description.bodies %}<tr><td>{{ b.name }}</td><td>{{ "%.4g" % b.mass }}</td>
<td>{{ "%.4g" % b.inertia }}</td></tr>{% endfor %}</table><p></p>
<table><tr><th>clearance joint</th><th>clearance (mm)</th><th>stiffness</th>
<th>restitution</th><th>contact law</th><th>friction</th></tr>
{% for j in n.description.contacts %}<tr><td>{{ j.name }}</td>
<td>{{ "%.4g" % (1000 * j.clearance) }}</td><td>{{ "%.3g" % j.stiffness }}</td>
<td>{{ j.restitution }}</td><td>{{ j.contact_model }}</td>
<td>{{ j.friction_law }} {{ j.friction_coefficient }}</td></tr>{% endfor %}</table>
<p>Initial rates: {% for k, v in n.description.initial.rates.items() %}{{ k }} = {{ v }}
{% if not loop.last %}, {% endif %}{% endfor %}.</p>

<h2>{{ titles.response }}</h2>
<p>Peaks of the monitored force per {{ "%.3g" % n.response.window }} s window (N):
{% for p in n.response.peaks %}{{ "%.6g" % p }}{% if not loop.last %}, {% endif %}{% endfor
%}.</p>
<table><tr><th>contact</th><th>contact onsets</th><th>largest penetration (m)</th>
<th>largest force (N)</th></tr>
{% for j, c in n.response.contacts.items() %}<tr><td>{{ j }}</td><td>{{ c.onsets }}</td>
<td>{{ "%.3g" % c.max_penetration }}</td><td>{{ "%.5g" % c.max_force }}</td></tr>
{% endfor %}</table>
{% for f in figs.response %}<img src="{{ img[f] }}" alt="{{ f }}">{% endfor %}

<h2>{{ titles.benchmark }}</h2>
{% if n.benchmark.skipped is defined %}<p>Not run: {{ n.benchmark.skipped }}.</p>{% else %}
<p>The compliant model (K = {{ "%.3g" % n.benchmark.stiffness }} N/m^1.5, rtol 1e-10)
against Moreau's midpoint scheme with rigid contacts (validation/moreau.py) at the steps
{% for h in n.benchmark.steps %}{{ h }}{% if not loop.last %}, {% endif %}{% endfor %} s,
extrapolated at first order; the bar is the distance of the finest step from the
extrapolation. Energy at the start {{ "%.4f" % n.benchmark.energy_start }} J.</p>
<table><tr><th></th><th>crank angle at the end (rad)</th><th>energy at the end (J)</th></tr>
<tr><td>compliant</td><td>{{ "%.5f" % n.benchmark.compliant.crank_angle }}</td>
<td>{{ "%.4f" % n.benchmark.compliant.energy }}</td></tr>
{% for h, m in n.benchmark.moreau.items() %}<tr><td>Moreau, h = {{ h }} s</td>
<td>{{ "%.5f" % m.crank_angle }}</td><td>{{ "%.4f" % m.energy }}</td></tr>{% endfor %}
<tr><td>Moreau, extrapolated</td><td>{{ "%.5f" % n.benchmark.moreau_extrapolated.crank_angle
}} +- {{ "%.2g" % n.benchmark.moreau_extrapolated.crank_angle_bar }}</td>
<td>{{ "%.4f" % n.benchmark.moreau_extrapolated.energy }} +- {{ "%.2g" %
n.benchmark.moreau_extrapolated.energy_bar }}</td></tr></table>
<p>First corner contact: {{ "%.5f" % n.benchmark.compliant.first_contact }} s (compliant),
{{ "%.5f" % n.benchmark.moreau_first_contact }} s (Moreau, sampled). Share of the time with
two opposite corners touching (a jammed slider), compliant:
{{ "%.3f" % n.benchmark.compliant_jammed_share }}.</p>
{% for f in figs.benchmark %}<img src="{{ img[f] }}" alt="{{ f }}">{% endfor %}{% endif %}

<h2>{{ titles.environment }}</h2>
<p>{{ n.environment.machine }}; Python {{ n.environment.python }};
{% for k, v in n.environment.versions.items() %}{{ k }} {{ v }}{% if not loop.last %},
{% endif %}{% endfor %}.</p>
</body></html>
"""


def render(out: Path, numbers: dict, figs: dict) -> Path:
    """Write report.html from the numbers and the figure files (embedded)."""
    from .linkage_report import render_template

    return render_template(out, numbers, figs, TEMPLATE, TITLES)


def build_free_report(linkage, out: str | Path = "report", quick: bool = False,
                      progress: bool = True, force: bool = False,
                      duration: float | None = None) -> Path:
    """Run every section on the free `linkage`, draw, write HTML; returns the HTML's path
    (the folder staged beside `out` and moved into place at the end)."""
    from mbs_clearance._io import OutputDir, check_output_dir

    from .report import section_environment, write_report

    if linkage.drive is not None:
        raise ValueError(f"linkage {linkage.name!r} has a drive; its report is "
                         "linkage_report.build_linkage_report")
    out = Path(out)
    check_output_dir(out, "--out", force)
    s = settings(quick, duration)
    with OutputDir(out, "report") as staged:
        work = staged.path
        (work / "data").mkdir()
        (work / "figures").mkdir()

        def compute(key, numbers, timings):
            if key == "environment":
                return section_environment(work, s, timings)
            return globals()[f"section_{key}"](linkage, work, s)

        write_report(staged, SECTIONS, compute, progress, draw_figures, render)
    return out / "report.html"
