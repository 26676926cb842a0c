"""The model specialised on a description's zero-valued geometry against the general one,
in one process (docs/cases.md, "Zero offsets are structure").

Both modules of a named case (`load_model(linkage)` and `load_model(linkage,
specialise=False)`) run the same plain run (`linkage_model.run`, 4 revolutions, default
tolerances; recorded and peak only) in alternating pairs; printed: the median of the
per-pair ratios specialised / general, each side's nfev and revolution-4 peak, and one
`rhs` call of each (`case_speed.model_rhs_ns` over the recorded states of a run).

    python -m benchmarks.specialised_ab [--case paper_slider_crank] [--pairs 21]
"""

from __future__ import annotations

import argparse
from unittest import mock

from mbs_clearance.generate import load_model
from mbs_clearance.model import cases
from mbs_clearance.solve import linkage_model as lm
from validation.timing import machine_summary, paired

from .case_speed import model_rhs_ns


def _run(linkage, model, record):
    """`linkage_model.run` on the given module (its `load_model` replaced for the call)."""
    with mock.patch.object(lm, "load_model", lambda *a, **k: model):
        return lm.run(linkage, 4, record=record)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="paper_slider_crank")
    ap.add_argument("--pairs", type=int, default=21)
    args = ap.parse_args(argv)
    linkage = getattr(cases, args.case)()
    spec, gen = load_model(linkage), load_model(linkage, specialise=False)
    print(machine_summary())
    print(f"{args.case}: specialised on {len(spec.ZERO_PARAMETERS)} zero-valued parameters")
    print("| run | specialised / general (median of pairs) | ms specialised / general | "
          "nfev | rev-4 peak specialised / general |")
    print("|---|---|---|---|---|")
    for record in (True, False):
        a, b = _run(linkage, spec, record), _run(linkage, gen, record)   # warm-up
        r = paired(lambda rec=record: _run(linkage, gen, rec),
                   lambda rec=record: _run(linkage, spec, rec), args.pairs)
        print(f"| {'recorded' if record else 'peak only'} | {r['ratio']:.3f} | "
              f"{1e3 * r['b']:.2f} / {1e3 * r['a']:.2f} | {a[6]['nfev']} / {b[6]['nfev']} | "
              f"{a[4][-1]:.10g} / {b[4][-1]:.10g} |")
    _, ts, ys, ms, *_ = _run(linkage, gen, True)
    ns = [model_rhs_ns(model, ts, ys, ms, lm.pack_parameters(linkage, model))
          for model in (spec, gen)]
    print(f"one rhs call: {ns[0]:.1f} ns specialised, {ns[1]:.1f} ns general")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
