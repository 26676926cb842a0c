"""The worker of `benchmarks.core_ab`: reads a run's name per line from stdin, runs it on
the mbs-clearance its interpreter imports, and writes "seconds cpu_seconds value" per line
(wall time, and the CPU time of its thread: what other processes' load leaves out). Uses only
interfaces that earlier releases have too (named cases, `linkage_model.run`,
`sensitivities`)."""

from __future__ import annotations

import sys
import time
import warnings

#: name -> (case, run keywords; "ddm": the parameters of a DDM run)
RUNS = {
    "paper, recorded": ("paper_slider_crank", dict(revolutions=4)),
    "paper, peak only": ("paper_slider_crank", dict(revolutions=4, record=False)),
    "paper DDM, 8 parameters": ("paper_slider_crank", dict(revolutions=4, ddm=(
        "crank.pin.x", "coupler.slider_end.x", "coupler.mass", "slider.mass",
        "coupler_slider.contact_stiffness", "coupler_slider.youngs_modulus",
        "coupler_slider.journal_radius", "coupler_slider.restitution"))),
    "four_bar": ("four_bar", dict(revolutions=1)),
    "lubricated (rodas4)": ("paper_slider_crank_lubricated",
                            dict(revolutions=1, method="rodas4")),
    "translational benchmark": ("flores_translational_slider_crank",
                                dict(duration=0.05, window=0.01)),
}


def run(name: str) -> tuple[float, float, float]:
    """(wall time in s, CPU time in s, the run's last peak or its DDM's largest
    |derivative|)."""
    import numpy as np

    from mbs_clearance.analysis.sensitivity import sensitivities
    from mbs_clearance.model import cases
    from mbs_clearance.solve import linkage_model as lm

    case, options = RUNS[name]
    linkage = cases.CASES[case]()
    options = dict(options)
    names = options.pop("ddm", None)
    t0, c0 = time.perf_counter(), time.thread_time()
    if names is None:
        value = float(lm.run(linkage, **options).peaks[-1])
    else:
        value = float(np.max(np.abs(sensitivities(linkage, names, **options).base_force)))
    return time.perf_counter() - t0, time.thread_time() - c0, value


def main() -> None:
    warnings.simplefilter("ignore")      # the runs' accuracy notes are not measured here
    for line in sys.stdin:
        seconds, cpu, value = run(line.strip())
        print(f"{seconds!r} {cpu!r} {value!r}", flush=True)


if __name__ == "__main__":
    main()
