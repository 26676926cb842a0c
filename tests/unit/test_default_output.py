"""One default output per linkage: `simulate`'s peaks, `peak_base_force`, `peak_output`,
`peak_gradient`, the GA's evaluation of the nominal design and the tolerance study's
nominal value are the peak of the same output (`Linkage.default_output`), on every named
case.

The reference is `simulate`'s recorded run at a fixed rtol: the peak-only run at the same
rtol takes the same steps (recording changes no step), so every entry point that makes
that run must give the same number exactly; the DDM run of the paper's cases steps on the
sensitivities' error too, so its peak is compared within the accuracy of two runs at rtol
1e-9 (measured 0.9e-7 to 1.6e-7 here; 1e-6 allowed: ten times the runs' tolerance times the
peak's sensitivity to the step sequence, cf. `PEAK_GRADIENT_RTOL`'s measurement).
"""

from __future__ import annotations

import numpy as np
import pytest

from mbs_clearance import CASES, peak_base_force, peak_gradient, simulate
from mbs_clearance.analysis.objective import parse_output, peak_output
from mbs_clearance.model.design import design_value, slider_crank_of
from mbs_clearance.studies import tolerance as tol
from mbs_clearance.studies.optimize import optimize_link_lengths

RTOL = 1e-9
#: a free linkage's window (s): the Flores case's first 10 ms hold its first impacts
WINDOW = 0.01
#: the DDM run's peak against the plain run's (see the module docstring)
DDM_AGREE = 1e-6


def _span(linkage):
    """(revolution, window) of the objective and `simulate`'s span keywords."""
    if linkage.drive is None:
        return 1, WINDOW, {"duration": WINDOW, "window": WINDOW}
    return 1, None, {"revolutions": 1}


@pytest.mark.parametrize("case", sorted(CASES))
def test_default_output_is_one_number_everywhere(case):
    linkage = CASES[case]()
    k, window, span = _span(linkage)
    name = linkage.default_output
    # the monitored joint's reaction, else the shaking force (the four-bar: no monitor)
    assert name == (f"pivot_force:{linkage.monitor_joint}" if linkage.monitor_joint
                    else "shaking_force")
    assert parse_output(linkage).name == name

    traj = simulate(linkage, rtol=RTOL, **span)
    assert traj.output == name
    ref = float(traj.peaks[k - 1])
    assert ref > 0.0

    # the peak-only run at the same rtol: the same steps, the same number
    assert peak_base_force(linkage, None if window else k, rtol=RTOL,
                           **({"duration": WINDOW, "window": WINDOW} if window else {})) == ref
    assert peak_output(linkage, None, k, window=window, rtol=RTOL) == ref

    pg = peak_gradient(linkage, ["crank_length"], revolution=k, window=window, method="fd",
                       rtol=RTOL, fd_relative_step=1e-4)
    assert pg.stats["output"] == name and pg.peak == ref

    b0 = design_value(linkage, "crank_length")
    ga = optimize_link_lengths(linkage, genes={"crank_length": (0.99 * b0, 1.01 * b0)},
                               revolution=k, window=window, population=4, generations=1,
                               refine=False, seed=0, progress=False, executor="serial",
                               rtol=RTOL)
    assert ga.settings["output"] == name and ga.original_peak_force == ref

    problem = tol.describe({"crank_length": tol.Uniform(0.99 * b0, 1.01 * b0)}, linkage,
                           "peak", k, window=window, rtol=RTOL)
    nominal = tol.ToleranceSample(method="monte_carlo", unit=np.array([[0.5]]),
                                  values=np.array([[b0]]))
    ev = tol.evaluate(problem, nominal, executor="serial", progress=False)
    assert ev.y[0] == ref


#: the cases whose peak gradient is by DDM unless told otherwise (the paper's parameter
#: set; `peak_gradient`'s method None)
DDM_CASES = [c for c in sorted(CASES) if slider_crank_of(CASES[c]()) is not None]


def test_ddm_cases_are_the_paper_sets():
    assert "paper_slider_crank" in DDM_CASES and "four_bar" not in DDM_CASES


@pytest.mark.parametrize("case", DDM_CASES)
def test_ddm_peak_is_the_default_output(case):
    """The DDM gradient's peak (the default method of these cases) of the default output
    within the accuracy of the runs (module docstring)."""
    linkage = CASES[case]()
    ref = float(simulate(linkage, 1, rtol=RTOL).peaks[0])
    pg = peak_gradient(linkage, ["crank_length"], revolution=1, method="ddm", rtol=RTOL)
    assert pg.stats["output"] == linkage.default_output
    assert abs(pg.peak / ref - 1.0) < DDM_AGREE


def test_a_translational_guide_may_be_the_monitored_joint():
    """A description monitoring its translational clearance guide (a joint to the ground
    with a reaction): that reaction is its default output, a name every study accepts, and
    its peak is `simulate`'s."""
    import dataclasses

    linkage = dataclasses.replace(CASES["flores_translational_slider_crank"](),
                                  monitor_joint="guide")
    assert linkage.default_output == "pivot_force:guide"
    traj = simulate(linkage, duration=WINDOW, window=WINDOW, rtol=RTOL)
    ref = float(traj.peaks[0])
    # the guide's recorded reaction: its largest sample, refined between steps to the peak
    sampled = float(np.hypot(*traj.reactions["guide"].T).max())
    assert sampled <= ref * (1 + 1e-12) and sampled > 0.99 * ref
    # not the crank pivot's: the guide's own reaction
    other = peak_output(linkage, "pivot_force:crank_pivot", 1, window=WINDOW, rtol=RTOL)
    assert abs(ref / other - 1.0) > 1e-3
    assert peak_output(linkage, None, 1, window=WINDOW, rtol=RTOL) == ref


def test_every_output_name_is_allowed_once():
    """The allowed outputs of every named case are distinct (each contact once, whichever
    element brings it) and hold every contact's force."""
    for name in CASES:
        lk = CASES[name]()
        with pytest.raises(ValueError) as err:
            parse_output(lk, "no such output")
        allowed = eval(str(err.value).split("allowed: ", 1)[1])  # noqa: S307 - our list
        assert len(allowed) == len(set(allowed)), (name, allowed)
        contacts = [n for n, _ in lk.contacts()]
        assert [a for a in allowed if a.startswith("contact_force:")] == [
            f"contact_force:{c}" for c in contacts], name
