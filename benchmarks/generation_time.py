"""What a user waits for once per new linkage structure: generation and first compile.

For a structure never seen before, in a fresh cache directory: a small four-bar-like
linkage whose names carry a fresh tag (default), or a named case (`--case NAME`, repeatable,
or `--case all`) with one unused point of a fresh name added to its first body (the
generated model is keyed by the structure, names included: no cache applies, the model is
the case's):

1. `generate_module` (sympy derivation, C printing);
2. `load_model`: the model derived again (`generate_module` caches nothing) and compiled;
3. the first calls of the model (prepare, closure, outputs);
4. the first and a second simulation (the core compiled once for every model);
5. a second process loading the same structure (everything from the disk caches).

    python -m benchmarks.generation_time [--case all]

Run it on a quiet machine: the times are the point of the script.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
import uuid


def _linkage(tag: str):
    from mbs_clearance.model.linkage import GROUND, Body, ClearanceJoint, Drive, Linkage, Revolute

    crank, coupler, rocker = f"crank_{tag}", f"coupler_{tag}", f"rocker_{tag}"
    return Linkage(
        name=f"bench_{tag}",
        bodies=(Body(crank, 0.1, 1e-4, {"o": (-0.01, 0.0), "a": (0.01, 0.0)}),
                Body(coupler, 0.2, 1e-3, {"a": (-0.05, 0.0), "b": (0.05, 0.0)}),
                Body(rocker, 0.2, 1e-3, {"o": (-0.04, 0.0), "b": (0.04, 0.0)})),
        joints=(Revolute("o2", GROUND, "o2", crank, "o"),
                Revolute("a", crank, "a", coupler, "a"),
                Revolute("o4", GROUND, "o4", rocker, "o")),
        clearance_joints=(ClearanceJoint("b", coupler, "b", rocker, "b", 0.005, 0.00499),),
        drive=Drive("o2", 50.0),
        ground_points={"o2": (0.0, 0.0), "o4": (0.08, 0.0)},
        assembly={f"{coupler}.angle": 1.3, f"{rocker}.angle": 1.9},
    )


def _structure(case: str | None, tag: str):
    """The bench linkage (case None) or the named case with an unused point named by `tag`
    on its first body (a new structure, the same model)."""
    if case is None:
        return _linkage(tag)
    import dataclasses

    from mbs_clearance.model.cases import CASES

    lk = CASES[case]()
    first = lk.bodies[0]
    tagged = dataclasses.replace(first, points={**first.points, f"tag_{tag}": (0.0, 0.0)})
    return lk.replace(bodies=(tagged, *lk.bodies[1:]))


def main(argv=None) -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", action="append",
                    help="a named case (repeatable), or 'all'; default: the bench linkage")
    args = ap.parse_args(argv)
    cache = tempfile.mkdtemp(prefix="mbs-gen-bench-")
    os.environ["MBS_CLEARANCE_CACHE_DIR"] = cache
    t0 = time.perf_counter()
    import mbs_clearance  # noqa: F401 - the library loads first (not counted)

    t_import = time.perf_counter() - t0
    cases = args.case or [None]
    if "all" in cases:
        from mbs_clearance.model.cases import CASES

        cases = list(CASES)
    print(f"library import (not counted): {t_import:.2f} s")
    for case in cases:
        _measure(case, cache)


def _measure(case, cache) -> None:
    from mbs_clearance.generate import generate_module, load_model
    from mbs_clearance.solve.linkage_model import initial_state, pack_parameters

    tag = uuid.uuid4().hex[:8]
    lk = _structure(case, tag)
    t0 = time.perf_counter()
    generate_module(lk)
    t_gen = time.perf_counter() - t0
    t0 = time.perf_counter()
    model = load_model(lk)           # derives again (not cached yet) and compiles
    t_load = time.perf_counter() - t0
    t0 = time.perf_counter()
    p = pack_parameters(lk, model)
    y0 = initial_state(lk, model, p)
    import numpy as np

    model.outputs(np.zeros(1), y0[None, :], np.zeros((1, model.N_MEM)), p)
    t_glue = time.perf_counter() - t0
    rows = [("generate_module (sympy, C printing)", t_gen),
            ("load_model (derivation again, compile)", t_load),
            ("first model calls (prepare, closure, outputs)", t_glue)]
    try:
        from mbs_clearance import simulate

        # one revolution; a free linkage: one of its time scales
        span = {"revolutions": 1} if lk.drive is not None else {"duration": lk.time_scale}
        t0 = time.perf_counter()
        simulate(lk, **span)
        rows.append(("first simulation (1 revolution)",
                     time.perf_counter() - t0))
        t0 = time.perf_counter()
        simulate(lk, **span)
        rows.append(("second simulation (1 revolution)", time.perf_counter() - t0))
    except (ImportError, AttributeError, NotImplementedError) as exc:
        rows.append((f"simulation not available ({exc})", float("nan")))
    code = (f"import time, os; t0 = time.perf_counter(); "
            f"from {__package__}.generation_time import _structure; "
            f"from mbs_clearance.generate import load_model; "
            f"lk = _structure({case!r}, {tag!r}); "
            f"t1 = time.perf_counter(); load_model(lk); "
            f"print(time.perf_counter() - t1)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=dict(os.environ), check=True).stdout.strip().splitlines()[-1]
    rows.append(("another process: load from the caches", float(out)))
    print(f"new structure of {case or lk.name} (tag {tag}, cache {cache})")
    for name, sec in rows:
        print(f"  {name:<58} {sec:8.2f} s")


if __name__ == "__main__":
    main()
