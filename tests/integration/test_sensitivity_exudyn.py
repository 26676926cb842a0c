"""DDM on the reduced model against finite differences of perturbed Exudyn runs."""

import numpy as np
import pytest

from mbs_clearance.analysis.sensitivity import sensitivities

pytestmark = pytest.mark.exudyn


def _rms_difference(mech, names, step, revolutions=2):
    """Relative RMS of DDM - Exudyn FD of d|F12|/db over the last revolution, per name."""
    fd = sensitivities(mech, names, revolutions=revolutions, method="fd", backend="exudyn",
                       fd_relative_step=1e-4, step_size=step)
    t = fd.t[fd.revolution_mask(revolutions)][::max(1, round(1e-5 / step))]
    ddm = sensitivities(mech, names, revolutions=revolutions, t_eval=t, rtol=1e-10)
    out = []
    for k in range(len(names)):
        a = ddm.base_force_magnitude[:, k]
        b = np.interp(t, fd.t, fd.base_force_magnitude[:, k])
        out.append(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(a**2)))
    return np.array(out)


def test_exudyn_fd_converges_to_ddm(paper):
    """The sensitivities oscillate at the contact frequency, so a derivative magnifies
    Exudyn's phase error: 15-19 % RMS at its default step 2e-6 s, 4-5 % at 1e-6 s, 1.2 % at
    5e-7 s (measured). We assert the second-order convergence (x4 per halving, allow >= 3)
    and the 'few percent' at 1e-6 s."""
    names = ["crank_length", "slider_mass"]
    coarse = _rms_difference(paper, names, 2e-6)
    fine = _rms_difference(paper, names, 1e-6)
    assert np.all(fine < coarse / 3)
    assert np.all(fine < 0.06)


@pytest.mark.slow
def test_exudyn_fd_agrees_with_ddm_for_link_lengths_and_masses(paper):
    """All four kinematic parameters at step 5e-7 s: within 2 % RMS (measured 1.1-1.3 %)."""
    names = ["crank_length", "coupler_length", "coupler_mass", "slider_mass"]
    assert np.all(_rms_difference(paper, names, 5e-7) < 0.02)


@pytest.mark.slow
def test_exudyn_fd_of_a_linkage_agrees_with_the_reduced_model_fd():
    """Central differences (relative step 1e-2) of the 2nd revolution's refined peak and RMS
    of the |shaking force| of the paper case as a `Linkage`, through Exudyn (step 2e-6 s)
    and through the generated reduced model (rtol 1e-11). Compared with the reduced model's
    central differences, not DDM: the linkage DDM (helper "ddm", DDM-LINKAGE) was not on
    its branch when this was written. Measured relative differences: d RMS / d coupler.mass
    1.0e-4, d RMS / d slider.mass 4.1e-5, d RMS / d coupler.inertia 6.8e-2 (the inertia
    moves the RMS by only ~1e-3 per 1 %: the difference is at Exudyn's own error level);
    d peak / d mass 3.1e-2 and 2.0e-2 (the peak's 2e-4 error divided by the 1e-2 step).
    Asserted: RMS 1e-3 (masses), 0.15 (inertia); peak 0.06 (masses)."""
    from mbs_clearance import simulate
    from mbs_clearance.model import cases
    from validation.compare import shaking_magnitude

    lk = cases.paper_slider_crank()

    def outputs(linkage, backend):
        opts = dict(rtol=1e-11) if backend == "reduced" else dict(step_size=2e-6)
        tr = simulate(linkage, 2, backend=backend, **opts)
        m = tr.revolution_mask(2)
        s, t = shaking_magnitude(tr)[m], tr.t[m]
        return np.array([tr.peaks[1], np.sqrt(np.trapezoid(s * s, t) / (t[-1] - t[0]))])

    bodies = {b.name: b for b in lk.bodies}
    for name, peak_tol, rms_tol in (("coupler.mass", 0.06, 1e-3), ("slider.mass", 0.06, 1e-3),
                                    ("coupler.inertia", None, 0.15)):
        body, field = name.split(".")
        v = getattr(bodies[body], field)
        d = 1e-2 * v
        fd = {be: (outputs(lk.with_parameter(name, v + d), be)
                   - outputs(lk.with_parameter(name, v - d), be)) / (2 * d)
              for be in ("reduced", "exudyn")}
        rel = np.abs(fd["exudyn"] - fd["reduced"]) / np.abs(fd["reduced"])
        assert rel[1] < rms_tol, f"{name}: RMS derivative {rel[1]:.2e}"
        if peak_tol is not None:
            assert rel[0] < peak_tol, f"{name}: peak derivative {rel[0]:.2e}"
