"""Rewrite the measured tables of docs/performance.md and docs/sensitivity.md from the
outputs of the benchmark commands (run them first, with nothing else running):

    python -m benchmarks.speed_reduced --json results/speed_reduced.json \
        > results/speed_reduced.md
    python -m validation.work_precision --out results
    python -m benchmarks.ddm_speed > results/ddm_speed.md
    python -m validation.stress --backend reduced exudyn --json results/stress.json
    python tools/update_performance_docs.py
"""

from __future__ import annotations

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _table(text: str, first_header: str) -> str:
    """The markdown table of `text` whose header starts with `first_header`."""
    lines = text.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith(first_header))
    end = start
    while end < len(lines) and lines[end].startswith("|"):
        end += 1
    return "\n".join(lines[start:end])


def _replace_table(doc: str, first_header: str, new: str) -> str:
    old = _table(doc, first_header)
    return doc.replace(old, new)


def stress_table(path: Path) -> str:
    data = json.loads(path.read_text())
    rows = data["rows"]
    by_case: dict[str, dict] = {}
    for r in rows:
        by_case.setdefault(r["case"], {})[r["backend"]] = r
    out = ["| case | reduced: status, s | switches | energy error (e = 1) | last-rev. peak "
           "\\|F12\\| reduced / Exudyn (N) | difference |", "|---|---|---|---|---|---|"]
    for case, b in by_case.items():
        r, x = b["reduced"], b.get("exudyn")
        energy = r.get("energy_error")
        energy = f"{energy:.1e}" if energy is not None else ""
        peak_r = r.get("peak_last_revolution")
        if x is None or x["status"] == "skipped":
            diff = "skipped: " + "; ".join(x["reasons"]) if x else ""
            peaks = f"{peak_r:.1f} / -"
        else:
            peaks = f"{peak_r:.1f} / {x['peak_last_revolution']:.1f}"
            diff = f"{100 * (x['peak_last_revolution'] / peak_r - 1):+.2f} %"
        out.append(f"| {case} | {r['status']}, {r['seconds']:.2f} | {r['contact_switches']} "
                   f"| {energy} | {peaks} | {diff} |")
    return "\n".join(out)


def main() -> None:
    res = ROOT / "results"
    perf = (ROOT / "docs" / "performance.md").read_text()
    speed = (res / "speed_reduced.md").read_text()
    perf = _replace_table(perf, "| run (paper case, 4 revolutions)",
                          _table(speed, "| run (paper case, 4 revolutions)"))
    wp = (res / "work_precision.md").read_text()
    perf = _replace_table(perf, "| backend | method | setting", _table(wp, "| backend | method"))
    perf = _replace_table(perf, "| target |", _table(wp, "| target |"))   # the paper case's
    perf = _replace_table(perf, "| case | reduced: status", stress_table(res / "stress.json"))
    (ROOT / "docs" / "performance.md").write_text(perf)
    sens = (ROOT / "docs" / "sensitivity.md").read_text()
    ddm = (res / "ddm_speed.md").read_text()
    sens = _replace_table(sens, "| method | rtol |", _table(ddm, "| method | rtol |"))
    (ROOT / "docs" / "sensitivity.md").write_text(sens)
    (ROOT / "docs" / "figures" / "work_precision.png").write_bytes(
        (res / "work_precision.png").read_bytes())
    print("updated docs/performance.md, docs/sensitivity.md and docs/figures/work_precision.png;"
          " now revise the numbers in the prose")


if __name__ == "__main__":
    main()
