"""Cost of the Linkage DDM (generated Jacobians) against a plain simulation of the same
linkage, per named case: 4 revolutions (the four-bar: 1), every step recorded, default
tolerances; the DDM with the paper's 8 design parameters' counterparts (paper case) or 8
parameters of bodies, joints and drive. Reports nfev of both, the column work of one
sensitivity right-hand side (`linkage_ddm.tangent_work`) and the median over alternating
pairs (plain, DDM, plain, DDM, ...) of the time ratio DDM / plain, in one run.

    python -m benchmarks.linkage_ddm_speed [--pairs 5]
"""

from __future__ import annotations

import argparse

from mbs_clearance.analysis.sensitivity import sensitivities
from mbs_clearance.model import cases
from mbs_clearance.solve.linkage_ddm import prepare_sensitivity, setup, tangent_work
from mbs_clearance.solve.linkage_model import run
from validation.timing import machine_summary, paired

PARAMETERS = {
    "paper_slider_crank": ("crank.pin.x", "coupler.slider_end.x", "coupler.mass",
                           "slider.mass", "coupler_slider.contact_stiffness",
                           "coupler_slider.youngs_modulus", "coupler_slider.journal_radius",
                           "coupler_slider.restitution"),
    "slider_crank_two_clearances": ("crank.pin.x", "coupler.mass", "slider.mass",
                                    "crank_coupler.journal_radius",
                                    "coupler_slider.journal_radius",
                                    "crank_coupler.restitution",
                                    "coupler_slider.youngs_modulus", "drive.speed"),
    "four_bar": ("crank.pin.x", "coupler.mass", "rocker.mass", "rocker.inertia",
                 "coupler_rocker.journal_radius", "coupler_rocker.restitution",
                 "coupler_rocker.youngs_modulus", "drive.speed"),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=5)
    args = ap.parse_args(argv)
    print(machine_summary())
    for case, names in PARAMETERS.items():
        linkage = getattr(cases, case)()
        revs = 1 if case == "four_bar" else 4
        integrator = "dopri5" if case == "four_bar" else None
        plain = run(linkage, revs).stats
        ddm = sensitivities(linkage, names, revolutions=revs, integrator=integrator)
        res = paired(lambda lk=linkage, r=revs: run(lk, r),
                     lambda lk=linkage, nm=names, r=revs, i=integrator: sensitivities(
                         lk, nm, revolutions=r, integrator=i), args.pairs)
        sp = prepare_sensitivity(linkage, names, revs, rtol=1e-7)
        y0, p, _, _ = setup(sp.problem, sp.directions.directions, [1.0] * len(names))
        work = tangent_work(sp.problem.model, p)
        print(f"{case}: plain nfev {plain['nfev']}, DDM ({len(names)} parameters, "
              f"{work['directions']} directions) nfev {ddm.stats['nfev']}; per right-hand "
              f"side {work['state_columns']} state columns x {work['directions']} + "
              f"{work['parameter_pairs']} parameter pairs (full Jacobian "
              f"{work['jacobian_columns']} columns); time DDM / plain (median of "
              f"{args.pairs} pairs) {res['ratio']:.2f}")


if __name__ == "__main__":
    main()
