"""The report of any linkage: its response, both models, sensitivities, tolerances, regimes.

    mbs-clearance report --case four_bar [--set NAME=VALUE ...] [--quick] [--out DIR]
    mbs-clearance report --description my_linkage.json [--quick] [--out DIR]

The paper's report (`validation.report`) reproduces the paper's case; this one runs the same
studies on any description, with defaults taken from the linkage itself:

1. **Response**: the run to the requested accuracy (1e-5), its peaks per revolution with
   their error estimate, and the journal orbits, contact forces and monitored force.
2. **Both models**: the converged cross-check (`validation.compare.cross_check`: the
   reduced model at accuracy 1e-6, Exudyn at three steps, extrapolated, each with its
   error bar) per revolution, and the overlay at Exudyn's default step.
3. **Sensitivities**: the gradient of the last revolution's peak (`peak_gradient`) with
   respect to every clearance, contact stiffness (or the Young's modulus it is derived
   from) and restitution and the drive speed, normalised (d ln peak / d ln value).
4. **Tolerances**: Sobol indices of that peak over the clearances (+-20 %) and the
   contact stiffnesses (+-20 %), uniform (`tolerance_study`).
5. **Regimes**: the regime map over the first clearance joint's clearance (1/10 to 10
   times its value, log) and the drive speed (1/2 to 3/2 of it).

Writes ``report.html`` (figures embedded), ``report.json`` (every number), ``figures/``;
built beside ``--out`` and moved into place at the end, as the paper's report.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from .report import numbered_titles

#: relative half-width of the tolerance study's uniform ranges
TOLERANCE_SPREAD = 0.2

SECTIONS = ("description", "response", "agreement", "sensitivity", "tolerance", "regimes",
            "environment")

TITLES = numbered_titles(SECTIONS, {
    "description": "The linkage",
    "response": "Response: peaks per revolution and journal orbits",
    "agreement": "Both models: reduced model against Exudyn, converged",
    "sensitivity": "Sensitivities of the peak",
    "tolerance": "Tolerances: what the peak's spread comes from",
    "regimes": "Where the motion is periodic: regime map",
    "environment": "Environment",
}, ("environment",))


def settings(quick: bool, revolutions: int | None = None) -> dict[str, Any]:
    """The studies' sizes (quick: a small but complete report)."""
    return {
        "quick": quick,
        "revolutions": revolutions or (2 if quick else 4),
        "cross_check_revolutions": 1 if quick else 2,
        "tolerance_sobol": 8 if quick else 64,
        "regime_points": (3, 2) if quick else (12, 6),
        "regime_revolutions": 20 if quick else 60,
        "regime_keep": 9 if quick else 30,
        "regime_max_period": 4,
    }


def _stiffness_field(joint) -> str:
    """The value that sets a joint's contact stiffness: its own, or (derived by Eq. 9) the
    Young's modulus."""
    return "contact_stiffness" if joint.contact_stiffness is not None else "youngs_modulus"


def _joint_fields(linkage, restitution: bool = True) -> list[str]:
    """Dotted paths of every clearance joint's clearance, stiffness (or the Young's modulus
    it is derived from) and restitution."""
    return [f"{j.name}.{f}" for j in linkage.clearance_joints
            for f in ("clearance", _stiffness_field(j), "restitution")[:3 if restitution
                                                                          else 2]]


# ------------------------------------------------------------------------------ sections
def section_description(linkage, out: Path, s: dict) -> dict:
    return {
        "name": linkage.name, "case": linkage.case,
        "overrides": dict(linkage.overrides or {}),
        "bodies": [{"name": b.name, "mass": b.mass, "inertia": b.inertia,
                    "points": {k: list(v) for k, v in b.points.items()}}
                   for b in linkage.bodies],
        "joints": [{"name": j.name, "kind": type(j).__name__} for j in linkage.joints],
        "clearance_joints": [{
            "name": j.name, "clearance": j.clearance, "stiffness": j.stiffness,
            "restitution": j.restitution, "contact_model": j.contact_model,
            "friction_law": j.friction_law, "lubrication": j.lubrication}
            for j in linkage.clearance_joints],
        "drive_speed": linkage.drive.speed, "period": linkage.period,
        "gravity": linkage.gravity,
    }


def section_response(linkage, out: Path, s: dict) -> dict:
    from mbs_clearance import simulate
    from mbs_clearance.solve.accuracy import revolution_peaks

    traj = simulate(linkage, s["revolutions"])
    traj.save(out / "data" / "response.npz")
    st = traj.stats
    return {
        "output": traj.output,
        "peaks": [float(v) for v in revolution_peaks(traj)],
        "error_estimate": st.get("error_estimate"), "accuracy": st.get("accuracy"),
        "accuracy_ok": st.get("accuracy_ok"), "rtol": st.get("rtol"),
        "periodic": st.get("periodic"), "contact_onsets": st.get("contact_onsets"),
        "max_eccentricity_ratio": {
            j: float(np.max(np.hypot(*traj.eccentricity[:, k, :].T))
                     / linkage.clearance_joints[k].clearance)
            for k, j in enumerate(traj.joints)},
        "max_contact_force": {j: float(traj.contact_force[:, k].max())
                              for k, j in enumerate(traj.joints)},
    }


def section_agreement(linkage, out: Path, s: dict) -> dict:
    from mbs_clearance import simulate
    from mbs_clearance.backends.exudyn_linkage import make_settings

    from .compare import compare, cross_check, plot_linkage_comparison

    revs = s["cross_check_revolutions"]
    cc = cross_check(linkage, revs, accuracy=1e-6)
    rows = []
    for k in range(revs):
        order = float(cc.exudyn_order[k])
        rows.append({
            "revolution": k + 1, "reduced": float(cc.reduced[k]),
            "reduced_error": float(cc.reduced_error[k]), "exudyn": float(cc.exudyn[k]),
            "exudyn_error": float(cc.exudyn_error[k]),
            "order": order if math.isfinite(order) else None,
            "difference": float(cc.exudyn[k] / cc.reduced[k] - 1.0),
            "bars": float(cc.bars[k] / cc.reduced[k]),
            "verdict": "model difference" if cc.model_difference[k] else "agree"})
    step = make_settings({}).step(linkage)
    ref = simulate(linkage, revs, rtol=1e-10, h_max=step)
    ex = simulate(linkage, revs, backend="exudyn")
    res = compare(ref, ex, step_bars=False)
    plot_linkage_comparison(ref, ex, path=out / "figures" / "agreement.png")
    return {"rows": rows, "exudyn_steps": [float(h) for h in cc.exudyn_steps],
            "exudyn_step": step,
            "peak_diff_percent": [100 * r.peak_rel_diff for r in res.revolutions],
            "reduced_seconds": cc.reduced_seconds, "exudyn_seconds": cc.exudyn_seconds}


def section_sensitivity(linkage, out: Path, s: dict) -> dict:
    from mbs_clearance import peak_gradient

    names = [*_joint_fields(linkage), "drive.speed"]
    g = peak_gradient(linkage, names, revolution=s["revolutions"])
    normalized = np.asarray(g.gradient) * np.asarray(g.reference) / g.peak
    return {"names": names, "output": g.stats["output"], "peak": float(g.peak),
            "gradient": [float(v) for v in g.gradient],
            "normalized": [float(v) for v in normalized], "method": g.method,
            "kink": bool(g.kink), "message": g.message, "revolution": s["revolutions"]}


def section_tolerance(linkage, out: Path, s: dict) -> dict:
    from mbs_clearance import tolerance_study
    from mbs_clearance.model.design import design_value
    from mbs_clearance.studies.tolerance import Uniform

    names = _joint_fields(linkage, restitution=False)
    inputs = {}
    for n in names:
        v = design_value(linkage, n)
        inputs[n] = Uniform(v * (1 - TOLERANCE_SPREAD), v * (1 + TOLERANCE_SPREAD))
    res = tolerance_study(inputs, linkage, revolution=s["revolutions"],
                          sobol=s["tolerance_sobol"], second_order=False, progress=False)
    sob = res.sobol
    return {"names": names, "output": linkage.default_output, "spread": TOLERANCE_SPREAD,
            "S1": [float(v) for v in sob["S1"]], "ST": [float(v) for v in sob["ST"]],
            "S1_conf": [float(v) for v in sob["S1_conf"]],
            "ST_conf": [float(v) for v in sob["ST_conf"]], "runs": int(sob["runs"])}


def section_regimes(linkage, out: Path, s: dict) -> dict:
    from mbs_clearance import regime_map
    from mbs_clearance.analysis.poincare import REGIMES
    from mbs_clearance.studies.sweep import SweepAxis

    j = linkage.clearance_joints[0]
    nc, nw = s["regime_points"]
    w = linkage.drive.speed
    axes = [SweepAxis(f"{j.name}.clearance",
                      tuple(np.geomspace(j.clearance / 10, j.clearance * 10, nc)), "log"),
            SweepAxis("drive.speed", tuple(np.linspace(w / 2, 1.5 * w, nw)), "lin")]
    res = regime_map(linkage, axes, revolutions=s["regime_revolutions"],
                     keep=s["regime_keep"], max_period=s["regime_max_period"],
                     out=out / "data" / "regimes.nc", workers=1)
    ds = res.dataset
    regimes = ds["regime"].values
    return {"axes": [a.name for a in axes], "file": "regimes.nc",
            "counts": {REGIMES[int(k)]: int(np.sum(regimes == k)) for k in np.unique(regimes)},
            "points": int(regimes.size)}


def section_environment(linkage, out: Path, s: dict, timings: dict | None = None) -> dict:
    from .report import section_environment as paper_environment

    return paper_environment(out, s, timings or {})


# ------------------------------------------------------------------------------ figures
def draw_figures(out: Path, n: dict) -> dict[str, list[str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mbs_clearance import load_trajectory
    from mbs_clearance.plotting import plot_regime_map
    from mbs_clearance.studies.sweep import load_map

    figs: dict[str, list[str]] = {k: [] for k in SECTIONS}
    fdir = out / "figures"
    traj = load_trajectory(out / "data" / "response.npz")
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2))
    ax[0].plot(traj.t / traj.linkage.period, np.hypot(*traj.base_force.T), lw=0.8)
    ax[0].set(xlabel="drive revolutions", ylabel="monitored force (N)",
              title="monitored force")
    for k, name in enumerate(traj.joints):
        c = traj.linkage.clearance_joints[k].clearance
        ax[1].plot(traj.eccentricity[:, k, 0] / c, traj.eccentricity[:, k, 1] / c, lw=0.6,
                   label=name)
        ax[2].plot(traj.t / traj.linkage.period, traj.contact_force[:, k], lw=0.8,
                   label=name)
    th = np.linspace(0, 2 * np.pi, 200)
    ax[1].plot(np.cos(th), np.sin(th), "k--", lw=0.6)
    ax[1].set(aspect="equal", xlabel="x / clearance", ylabel="y / clearance",
              title="journal orbits")
    ax[1].legend(fontsize=8, loc="upper right")
    ax[2].set(xlabel="drive revolutions", ylabel="contact force (N)", title="contact forces")
    fig.tight_layout()
    fig.savefig(fdir / "response.png", dpi=110)
    plt.close(fig)
    figs["response"].append("response.png")
    if (fdir / "agreement.png").is_file():
        figs["agreement"].append("agreement.png")
    sens = n["sensitivity"]
    fig, ax = plt.subplots(figsize=(8, 0.4 * len(sens["names"]) + 1.2))
    ax.barh(sens["names"], sens["normalized"])
    ax.axvline(0.0, color="k", lw=0.6)
    ax.set(xlabel="d ln(peak) / d ln(value)",
           title=f"normalised sensitivities of revolution {sens['revolution']}'s peak")
    fig.tight_layout()
    fig.savefig(fdir / "sensitivity.png", dpi=110)
    plt.close(fig)
    figs["sensitivity"].append("sensitivity.png")
    tol = n["tolerance"]
    fig, ax = plt.subplots(figsize=(8, 0.5 * len(tol["names"]) + 1.2))
    y = np.arange(len(tol["names"]))
    ax.barh(y - 0.18, tol["S1"], 0.36, xerr=tol["S1_conf"], label="first order S1")
    ax.barh(y + 0.18, tol["ST"], 0.36, xerr=tol["ST_conf"], label="total ST")
    ax.set_yticks(y, tol["names"])
    ax.set(xlabel="Sobol index", title=f"uniform +-{100 * tol['spread']:.0f} %")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(fdir / "tolerance.png", dpi=110)
    plt.close(fig)
    figs["tolerance"].append("tolerance.png")
    ds = load_map(out / "data" / n["regimes"]["file"])
    plot_regime_map(ds, fdir / "regimes.png")
    figs["regimes"].append("regimes.png")
    return figs


TEMPLATE = """<!doctype html>
<html><head><meta charset="utf-8"><title>mbs-clearance report: {{ n.description.name }}</title>
<style>body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}
table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px;text-align:right}
th{background:#f3f3f3}img{max-width:100%}</style></head><body>
<h1>Report of the linkage "{{ n.description.name }}"</h1>
<p>{% if n.description.case %}Named case <code>{{ n.description.case }}</code>{% if
n.description.overrides %} with {% for k, v in n.description.overrides.items() %}<code>{{ k }}
= {{ v }}</code>{% if not loop.last %}, {% endif %}{% endfor %}{% endif %}.{% else %}A
description file.{% endif %} Drive speed {{ "%.4g" % n.description.drive_speed }} rad/s
(revolution {{ "%.4g" % n.description.period }} s). {% if quick %}<b>Quick report</b>: small
studies, for a first look.{% endif %}</p>

<h2>{{ titles.description }}</h2>
<table><tr><th>body</th><th>mass (kg)</th><th>inertia (kg m^2)</th></tr>
{% for b in n.description.bodies %}<tr><td>{{ b.name }}</td><td>{{ "%.4g" % b.mass }}</td>
<td>{{ "%.4g" % b.inertia }}</td></tr>{% endfor %}</table>
<p></p>
<table><tr><th>clearance joint</th><th>clearance (mm)</th><th>stiffness (N/m^1.5)</th>
<th>restitution</th><th>contact law</th><th>friction</th><th>lubrication</th></tr>
{% for j in n.description.clearance_joints %}<tr><td>{{ j.name }}</td>
<td>{{ "%.4g" % (1000 * j.clearance) }}</td><td>{{ "%.4g" % j.stiffness }}</td>
<td>{{ j.restitution }}</td><td>{{ j.contact_model }}</td><td>{{ j.friction_law }}</td>
<td>{{ j.lubrication }}</td></tr>{% endfor %}</table>

<h2>{{ titles.response }}</h2>
<p>Peaks of the monitored output, {{ n.response.output }}, per revolution (N):
{% for p in n.response.peaks %}{{ "%.6g" % p }}{% if not loop.last %}, {% endif %}{% endfor
%}. {% if n.response.error_estimate is not none %}The run's own estimate of their relative
error is {{ "%.2g" % n.response.error_estimate }} (requested {{ n.response.accuracy }}:
{{ "met" if n.response.accuracy_ok else "not met" }}).{% endif %} {% if n.response.periodic
%}The motion is periodic.{% elif n.response.periodic is sameas false %}The motion is not
periodic.{% else %}Whether the motion is periodic is not judged (too few revolutions).{% endif
%}</p>
<table><tr><th>joint</th><th>largest eccentricity / clearance</th>
<th>largest contact force (N)</th></tr>
{% for j, e in n.response.max_eccentricity_ratio.items() %}<tr><td>{{ j }}</td>
<td>{{ "%.3f" % e }}</td><td>{{ "%.5g" % n.response.max_contact_force[j] }}</td></tr>
{% endfor %}</table>
{% for f in figs.response %}<img src="{{ img[f] }}" alt="{{ f }}">{% endfor %}

<h2>{{ titles.agreement }}</h2>
<p>Per revolution the reduced model's peak of {{ n.response.output }} (accuracy 1e-6) and
Exudyn's extrapolated from
the steps {% for h in n.agreement.exudyn_steps %}{{ "%.3g" % h }}{% if not loop.last %},
{% endif %}{% endfor %} s, each with its error bar; "model difference" where the
difference exceeds the two bars together.</p>
<table><tr><th>revolution</th><th>reduced: peak of {{ n.response.output }} (N)</th><th>+-</th>
<th>Exudyn: peak of {{ n.response.output }} (N)</th><th>+-</th>
<th>difference</th><th>bars</th><th>verdict</th></tr>
{% for r in n.agreement.rows %}<tr><td>{{ r.revolution }}</td><td>{{ "%.7g" % r.reduced }}</td>
<td>{{ "%.2g" % r.reduced_error }}</td><td>{{ "%.7g" % r.exudyn }}</td>
<td>{{ "%.2g" % r.exudyn_error }}</td><td>{{ "%.2e" % r.difference }}</td>
<td>{{ "%.2e" % r.bars }}</td><td>{{ r.verdict }}</td></tr>{% endfor %}</table>
<p>At Exudyn's default step ({{ "%.3g" % n.agreement.exudyn_step }} s) its peaks differ by
{% for d in n.agreement.peak_diff_percent %}{{ "%.2f" % d }} %{% if not loop.last %},
{% endif %}{% endfor %} per revolution:</p>
{% for f in figs.agreement %}<img src="{{ img[f] }}" alt="{{ f }}">{% endfor %}

<h2>{{ titles.sensitivity }}</h2>
<p>The gradient of revolution {{ n.sensitivity.revolution }}'s peak of
{{ n.sensitivity.output }}, {{ "%.6g" % n.sensitivity.peak }} N
({{ methods.get(n.sensitivity.method, n.sensitivity.method) }}){% if n.sensitivity.kink %};
<b>{{ n.sensitivity.message }}</b>{% endif %}:</p>
<table><tr><th>value</th><th>d peak / d value</th><th>d ln peak / d ln value</th></tr>
{% for name in n.sensitivity.names %}<tr><td>{{ name }}</td>
<td>{{ "%.4g" % n.sensitivity.gradient[loop.index0] }}</td>
<td>{{ "%.4g" % n.sensitivity.normalized[loop.index0] }}</td></tr>{% endfor %}</table>
{% for f in figs.sensitivity %}<img src="{{ img[f] }}" alt="{{ f }}">{% endfor %}

<h2>{{ titles.tolerance }}</h2>
<p>Sobol indices of the peak of {{ n.tolerance.output }}, every input uniform within
+-{{ "%.0f" % (100 * n.tolerance.spread) }} % of its value ({{ n.tolerance.runs }} runs).</p>
{% for f in figs.tolerance %}<img src="{{ img[f] }}" alt="{{ f }}">{% endfor %}

<h2>{{ titles.regimes }}</h2>
<p>{{ n.regimes.points }} designs over {{ n.regimes.axes | join(" and ") }}; regimes:
{% for k, v in n.regimes.counts.items() %}{{ k }} {{ v }}{% if not loop.last %}, {% endif
%}{% endfor %}. Each point runs {{ n.environment.settings.regime_revolutions }} revolutions
and judges the last {{ n.environment.settings.regime_keep }}: a design still settling
from its start by then shows as aperiodic (a slowly settling linkage, such as the
four-bar, needs a longer map: `mbs-clearance map --revolutions`).</p>
{% for f in figs.regimes %}<img src="{{ img[f] }}" alt="{{ f }}">{% endfor %}

<h2>{{ titles.environment }}</h2>
<p>{{ n.environment.machine }}; Python {{ n.environment.python }};
{% for k, v in n.environment.versions.items() %}{{ k }} {{ v }}{% if not loop.last %},
{% endif %}{% endfor %}.</p>
</body></html>
"""


def render(out: Path, numbers: dict, figs: dict) -> Path:
    """Write report.html from the numbers and the figure files (embedded)."""
    return render_template(out, numbers, figs, TEMPLATE, TITLES)


def render_template(out: Path, numbers: dict, figs: dict, template: str,
                    titles: dict) -> Path:
    """Write report.html of `template` from the numbers and the figure files (embedded)."""
    import base64

    import jinja2

    img = {f: "data:image/png;base64," + base64.b64encode(
        (out / "figures" / f).read_bytes()).decode() for names in figs.values() for f in names}
    from mbs_clearance.plotting import METHOD_NAMES

    env = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined)
    html = env.from_string(template).render(n=numbers, figs=figs, img=img, titles=titles,
                                            quick=numbers["environment"]["settings"]["quick"],
                                            methods=METHOD_NAMES)
    path = out / "report.html"
    path.write_text(html)
    return path


def build_linkage_report(linkage, out: str | Path = "report", quick: bool = False,
                         progress: bool = True, force: bool = False,
                         revolutions: int | None = None) -> Path:
    """Run every section on `linkage` (a `Linkage`; a free one gets
    `free_report.build_free_report`), draw, write HTML; returns the HTML's path. The
    folder is built beside `out` and moved into place at the end (an existing `out` that
    is not an earlier report is replaced only with `force`)."""
    from mbs_clearance._io import OutputDir, check_output_dir
    from mbs_clearance.model.linkage import Linkage

    from .report import write_report

    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    if linkage.drive is None:
        from .free_report import build_free_report

        return build_free_report(linkage, out, quick=quick, progress=progress, force=force)
    out = Path(out)
    check_output_dir(out, "--out", force)
    s = settings(quick, revolutions)
    with OutputDir(out, "report") as staged:
        work = staged.path
        (work / "data").mkdir()
        (work / "figures").mkdir()

        def compute(key, numbers, timings):
            if key == "environment":
                return section_environment(linkage, work, s, timings)
            return globals()[f"section_{key}"](linkage, work, s)

        write_report(staged, SECTIONS, compute, progress, draw_figures, render)
    return out / "report.html"
