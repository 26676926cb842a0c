"""Direct differentiation against finite differences, identities and the paper's findings."""

import math

import numpy as np
import pytest

from mbs_clearance import SliderCrank, simulate
from mbs_clearance.analysis.sensitivity import (
    DEFAULT_PARAMETERS,
    independent_directions,
    sensitivities,
)
from mbs_clearance.solve import linkage_ddm


@pytest.fixture(scope="module")
def rev4(paper):
    return np.linspace(3 * paper.period, 4 * paper.period, 721)


@pytest.fixture(scope="module")
def ddm(paper, rev4):
    return sensitivities(paper, t_eval=rev4, rtol=1e-10)


@pytest.fixture(scope="module")
def fd(paper, rev4):
    return sensitivities(paper, method="fd", t_eval=rev4)


def test_ddm_trajectory_equals_the_plain_simulation(paper, rev4, ddm):
    """The nominal trajectory of a DDM run (state integrated with its sensitivities by DOP853,
    outputs from the generated Jacobian's value column, crank work from its drive moment)
    equals the plain model's (dopri5, the generated plain kernels) at the same output
    times."""
    plain = simulate(paper, 4, t_eval=rev4, rtol=1e-10)
    tr = ddm.trajectory
    np.testing.assert_array_equal(tr.t, plain.t)
    for name in ("base_force", "crank_moment", "contact_force", "slider_position",
                 "slider_velocity", "slider_acceleration", "coupler_angle", "crank_work"):
        a, b = getattr(tr, name), getattr(plain, name)
        err = np.max(np.abs(a - b)) / np.max(np.abs(b))
        assert err < 1e-6, (name, err)
    np.testing.assert_array_equal(tr.contact_phase, plain.contact_phase)


def test_growth_maxima_equals_a_loop():
    """The growth diagnostic (per revolution and parameter, the largest scaled norm of the
    state sensitivity) against the same maxima by an explicit loop over the steps, with a
    step on a revolution's edge (it counts for both sides)."""
    rng = np.random.default_rng(1)
    n, npar = 40, 3
    ts = np.sort(rng.uniform(0.0, 3.0, n))
    ts[[0, 17, -1]] = 0.0, 1.0, 3.0
    ts = np.sort(ts)
    sens = rng.normal(size=(n, npar, 4))
    scale, unit = rng.uniform(0.5, 2.0, npar), rng.uniform(0.5, 2.0, 4)
    ref = np.zeros((3, npar))
    for i in range(n):
        for r in range(3):
            if r <= ts[i] <= r + 1:
                for k in range(npar):
                    ref[r, k] = max(ref[r, k],
                                    math.sqrt(np.sum((sens[i, k] * scale[k] / unit) ** 2)))
    np.testing.assert_allclose(linkage_ddm.growth_maxima(ts, sens, scale, unit, 1.0, 3), ref,
                               rtol=1e-13)


def test_independent_directions():
    a, b = np.array([1.0, -2.0, 0.5, 0.0]), np.array([0.0, 1.0, 3.0, 1e-3])
    c = np.array([0.0, 0.0, 0.0, 1.0])
    # proportional, zero, combinations, and one off the span by 1e-9 (kept: tol is 1e-12)
    M = np.column_stack([np.zeros(4), a, 2.5 * a, b, a - 4 * b, b + 1e-9 * c])
    basis, C = independent_directions(M)
    assert list(basis) == [1, 3, 5]      # the zero column needs no integration
    np.testing.assert_allclose(M[:, basis] @ C, M, atol=1e-14)
    assert np.all(C[:, 0] == 0.0)
    basis, C = independent_directions(np.zeros((3, 1)))    # at least one column is kept
    assert list(basis) == [0]


def test_dependent_parameters_share_one_integration(paper, rev4, ddm, monkeypatch):
    """youngs_modulus, poisson_ratio and contact_stiffness enter through K alone: one
    integrated direction. crank_inertia (no effect at constant crank speed) is integrated
    (its chain is not zero: the crank's inertia is a parameter of the generated model) and
    stays exactly zero (its Jacobian columns are). The compressed result equals a run that
    integrates every parameter separately."""
    assert ddm.stats["directions"] == 7
    names = ["youngs_modulus", "crank_inertia", "poisson_ratio", "contact_stiffness",
             "journal_radius", "bearing_radius"]
    s = sensitivities(paper, names, t_eval=rev4, rtol=1e-10)
    # K alone; J2; c and K by R_J; R_B moves c and K too: a combination of the two
    assert s.stats["directions"] == 3
    assert np.all(s.base_force_magnitude[:, 1] == 0.0)
    monkeypatch.setattr(linkage_ddm, "independent_directions",
                        lambda M, tol=0.0: (np.arange(M.shape[1]), np.eye(M.shape[1])))
    full = sensitivities(paper, names, t_eval=rev4, rtol=1e-10)
    assert full.stats["directions"] == len(names)
    for k, name in enumerate(names):
        a, b = s.base_force_magnitude[:, k], full.base_force_magnitude[:, k]
        # two runs with different step sequences (the error norm sees different
        # components): they agree to the integration error at rtol 1e-10
        assert np.max(np.abs(a - b)) <= 1e-6 * np.max(np.abs(b)), name


def test_crank_speed_and_initial_angle_ddm_equals_finite_differences(paper):
    """The parameters that need the Jacobian's crank-angle columns (t, omega2, theta20), which
    the default set's right-hand side leaves out."""
    names = ["crank_speed", "initial_crank_angle"]
    # (a faster crank ends 4 revolutions earlier: the grid stops short of 4 T)
    t = np.linspace(3 * paper.period, 3.99 * paper.period, 721)
    d = sensitivities(paper, names, t_eval=t, rtol=1e-10)
    # a smaller step than the default 3e-5: the crank speed moves the phase by omega t
    # (25 rad by revolution 4), so FD's h^2 truncation error is 2e-3 at 3e-5, 2e-4 at 1e-5
    f = sensitivities(paper, names, t_eval=t, method="fd", fd_relative_step=3e-6)
    for k, name in enumerate(names):
        a, b = d.base_force_magnitude[:, k], f.base_force_magnitude[:, k]
        assert np.max(np.abs(a - b)) < 1e-4 * np.max(np.abs(a)), name


def test_ddm_equals_central_differences_for_every_default_parameter(ddm, fd):
    """d|F12|/db over revolution 4: DDM (rtol 1e-10) vs central differences (step 3e-5 b0,
    rtol 1e-11). FD's own error is ~1e-5 at this step (h^2 truncation vs integration noise),
    so 1e-4 of the series' maximum tests DDM to the accuracy FD can resolve."""
    assert ddm.parameters == DEFAULT_PARAMETERS
    for k, name in enumerate(ddm.parameters):
        a, b = ddm.base_force_magnitude[:, k], fd.base_force_magnitude[:, k]
        assert np.max(np.abs(a - b)) < 1e-4 * np.max(np.abs(a)), name
        for series in ("crank_moment", "contact_force"):
            a, b = getattr(ddm, series)[:, k], getattr(fd, series)[:, k]
            assert np.max(np.abs(a - b)) < 1e-4 * np.max(np.abs(a)), (name, series)


def test_ddm_equals_central_differences_in_every_revolution(paper):
    """As above over revolutions 1 to 4, impacts included: every recorded step must carry
    its own memory sensitivities (a run that recorded all but the last direction's had the
    last parameter, restitution, off by 1.6e-3 in revolution 1, where the impacts change
    it). FD is 3e-5 to 9e-5 from DDM in revolution 1 (the impacts), so 3e-4 per revolution."""
    grid = np.linspace(0.0, 4 * paper.period, 2881)
    d = sensitivities(paper, t_eval=grid, rtol=1e-10)
    f = sensitivities(paper, method="fd", t_eval=grid)
    for k, name in enumerate(d.parameters):
        for rev in range(1, 5):
            mask = d.revolution_mask(rev)
            a, b = d.base_force_magnitude[mask, k], f.base_force_magnitude[mask, k]
            assert np.max(np.abs(a - b)) < 3e-4 * np.max(np.abs(b)), (name, rev)


def test_event_time_term_is_needed(paper, rev4, fd):
    """Without the event-time term of the impact-velocity sensitivity DDM misses by percents
    (the memory set at the last onset persists through the steady contact)."""
    wrong = sensitivities(paper, t_eval=rev4, rtol=1e-10, event_time_term=False)
    errors = [np.max(np.abs(wrong.base_force_magnitude[:, k] - fd.base_force_magnitude[:, k]))
              / np.max(np.abs(fd.base_force_magnitude[:, k])) for k in range(8)]
    assert min(errors) > 1e-3 and max(errors) > 0.1


def test_youngs_modulus_and_contact_stiffness_normalized_sensitivities_are_equal(
        paper, rev4, monkeypatch):
    """K is proportional to E (Eq. 9), so (dJ/dE) E = (dJ/dK) K exactly (paper, Fig. 5).
    Checked with both integrated (the default shares one integration between them), through
    the description's chain (Eq. 9's partials) and the Jacobian's stiffness column."""
    monkeypatch.setattr(linkage_ddm, "independent_directions",
                        lambda M, tol=0.0: (np.arange(M.shape[1]), np.eye(M.shape[1])))
    s = sensitivities(paper, ["youngs_modulus", "contact_stiffness"], t_eval=rev4, rtol=1e-10)
    assert s.stats["directions"] == 2
    e, k = s.normalized[:, 0], s.normalized[:, 1]
    assert np.max(np.abs(e - k)) < 1e-10 * np.max(np.abs(k))


def test_paper_findings(ddm):
    """Paper: |F12| is more sensitive to link lengths and masses than to the contact
    properties over most of the cycle, and the journal radius dominates all."""
    n = np.abs(ddm.normalized)
    kin = [ddm.column(p) for p in ("crank_length", "coupler_length", "coupler_mass",
                                   "slider_mass")]
    con = [ddm.column(p) for p in ("contact_stiffness", "youngs_modulus", "restitution")]
    assert np.mean(n[:, kin].min(axis=1) > n[:, con].max(axis=1)) > 0.5
    assert np.all(n[:, kin].max(axis=1) > n[:, con].max(axis=1))
    j = ddm.column("journal_radius")
    others = np.delete(n, j, axis=1).max(axis=1)
    assert np.all(n[:, j] > others)
    assert np.median(n[:, j] / others) > 100


def test_periodic_case_is_not_flagged_but_large_clearances_are(paper, ddm):
    assert not ddm.chaotic
    assert np.all(np.abs(ddm.growth_rate - 1.0) < 0.3)
    for c in (1e-4, 5e-4):
        s = sensitivities(paper.replace(journal_radius=0.01 - c), ["slider_mass"], rtol=1e-8)
        assert s.chaotic, c


def test_fd_and_ddm_on_default_grid_and_normalization_floor(paper):
    s = sensitivities(paper, ["slider_mass"], revolutions=1)
    assert np.all(np.isfinite(s.normalized))
    assert s.base_force.shape == (len(s.t), 2, 1)


@pytest.mark.parametrize("kwargs,message", [
    ({"parameters": ["crank_lenght"]}, "unknown parameter name"),
    ({"parameters": ["contact_model"]}, "unknown parameter name"),
    ({"method": "adjoint"}, r"method must be one of \['ddm', 'fd'\]"),
    ({"backend": "exudyn"}, "method='ddm' needs backend='reduced'"),
    ({"backend": "adams", "method": "fd"}, "backend must be one of"),
    ({"fd_relative_step": 0.5, "method": "fd"},
     r"fd_relative_step must be a finite number in \(0, 0.1\)"),
    ({"parameters": ["slider_mass", "slider_mass"]}, "must not repeat"),
    ({"integrator": "rk4"}, "integrator must be one of"),
])
def test_bad_input(paper, kwargs, message):
    with pytest.raises(ValueError, match=message):
        sensitivities(paper, **kwargs)


def test_fd_step_leaving_valid_range_is_reported():
    with pytest.raises(ValueError, match="leaves its valid range"):
        sensitivities(SliderCrank(restitution=1.0), ["restitution"], method="fd",
                      revolutions=1)


def test_save_load_roundtrip(ddm, tmp_path):
    from mbs_clearance.analysis.sensitivity import load_sensitivities

    back = load_sensitivities(ddm.save(tmp_path / "s.npz"))
    assert back.parameters == ddm.parameters and back.method == "ddm"
    np.testing.assert_array_equal(back.normalized, ddm.normalized)
    np.testing.assert_array_equal(back.growth, ddm.growth)
    with pytest.raises(ValueError, match="cannot read sensitivities file"):
        load_sensitivities(tmp_path / "missing.npz")


@pytest.mark.slow
def test_ddm_with_friction_matches_central_differences():
    """A SliderCrank with friction (Ambrosio, mu 0.05) differentiates on its friction model:
    DDM of |F12| for the friction coefficient and the crank length agrees with central
    differences at rtol 1e-10 (measured 1.1e-3 RMS, the differences' truncation); without a
    friction law the derivative for mu is exactly zero (the law ignores mu)."""
    from mbs_clearance import SliderCrank, sensitivities

    mech = SliderCrank(friction_law="ambrosio", friction_coefficient=0.05)
    names = ["friction_coefficient", "crank_length"]
    te = np.linspace(0.0, 2 * mech.period, 801)[1:]
    d = sensitivities(mech, names, revolutions=2, method="ddm", t_eval=te)
    f = sensitivities(mech, names, revolutions=2, method="fd", t_eval=te, rtol=1e-10)
    np.testing.assert_array_equal(d.t, f.t)
    for k in range(2):
        a, b = d.base_force_magnitude[:, k], f.base_force_magnitude[:, k]
        assert np.sqrt(np.mean((a - b) ** 2)) < 5e-3 * np.sqrt(np.mean(b ** 2)), names[k]
    d0 = sensitivities(SliderCrank(), names, revolutions=1, method="ddm")
    assert np.all(d0.base_force_magnitude[:, 0] == 0.0)
    assert np.abs(d0.base_force_magnitude[:, 1]).max() > 0.0
