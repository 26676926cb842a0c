"""Direct differentiation against finite differences, identities and the paper's findings."""

import numpy as np
import pytest

from mbs_clearance import SliderCrank, reduced, simulate
from mbs_clearance import sensitivity as sens_module
from mbs_clearance._jacobians import (
    CRANK_COLUMNS,
    N_Z,
    N_ZO,
    N_ZW,
    accel_constants,
    contact_accel,
    contact_accel_nc,
    contact_branch,
    contact_outputs,
    contact_outputs_nc,
    free_accel,
    free_accel_nc,
    free_branch,
    free_outputs,
    free_outputs_nc,
)
from mbs_clearance.contact import hysteresis_factor
from mbs_clearance.sensitivity import DEFAULT_PARAMETERS, independent_directions, sensitivities


@pytest.fixture(scope="module")
def rev4(paper):
    return np.linspace(3 * paper.period, 4 * paper.period, 721)


@pytest.fixture(scope="module")
def ddm(paper, rev4):
    return sensitivities(paper, t_eval=rev4, rtol=1e-10)


@pytest.fixture(scope="module")
def fd(paper, rev4):
    return sensitivities(paper, method="fd", t_eval=rev4)


def _z(mech, t, y, dmin):
    xi, _ = hysteresis_factor(mech.restitution, 0)
    return np.array([t, y[0], y[1], y[2], y[3], dmin, mech.crank_length, mech.coupler_length,
                     mech.crank_mass, mech.coupler_mass, mech.slider_mass,
                     mech.coupler_inertia_value, mech.crank_speed, mech.initial_crank_angle,
                     mech.clearance, mech.stiffness, xi, mech.gravity])


@pytest.mark.parametrize("branch", [contact_branch, free_branch])
def test_generated_jacobian_matches_hand_written_model_and_finite_differences(paper, branch):
    """The sympy-generated outputs equal reduced.dynamics (written by hand) and every partial
    derivative equals central differences (best of several steps: delta is ~1e-6 m)."""
    ts, ys, ms, *_ = reduced.run(paper, 2)
    p = reduced.pack_parameters(paper)      # the hand-written kernels' layout
    i = 3 * len(ts) // 4
    assert ms[i, 0] == 1.0  # a state in contact
    z = _z(paper, ts[i], ys[i], ms[i, 1])
    o, flat = np.zeros(8), np.zeros(8 * N_Z)
    branch(z, o, flat)
    jac = flat.reshape(8, N_Z)
    if branch is contact_branch:
        q = p.copy()
        q[reduced.P_MODE], q[reduced.P_DMIN] = ms[i]
        ref = np.array(reduced.dynamics(ts[i], ys[i], q))[[0, 1, 8, 9, 7, 2, 3, 4]]
        # the two codes round differently: delta (~1e-6 m) is a difference of coordinates of
        # size L2 + L3, so its relative round-off is ~eps (L2 + L3) / delta ~ 4e-11
        np.testing.assert_allclose(o, ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())
    for j in range(N_Z):
        best = np.inf
        for rel in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9):
            h = rel * max(abs(z[j]), 1e-3)
            zp, zm = z.copy(), z.copy()
            zp[j] += h
            zm[j] -= h
            op, om = np.zeros(8), np.zeros(8)
            branch(zp, op, np.zeros(8 * N_Z))
            branch(zm, om, np.zeros(8 * N_Z))
            err = np.max(np.abs((op - om) / (2 * h) - jac[:, j]))
            best = min(best, err / (np.abs(jac[:, j]).max() + 1e-300))
        assert best < 1e-6, (j, best)


@pytest.mark.parametrize("branch,accel,accel_nc", [
    (contact_branch, contact_accel, contact_accel_nc), (free_branch, free_accel, free_accel_nc)])
def test_acceleration_only_variants_equal_the_full_branch(paper, branch, accel, accel_nc):
    """The right-hand side's *_accel functions (their parameter-only temporaries computed once
    by accel_constants; the _nc variants without the crank-angle columns) give the full
    branch's first two rows."""
    ts, ys, ms, *_ = reduced.run(paper, 2)
    i = 3 * len(ts) // 4
    z = _z(paper, ts[i], ys[i], ms[i, 1])
    o, flat = np.zeros(8), np.zeros(8 * N_Z)
    branch(z, o, flat)
    zw = np.zeros(N_ZW)
    zw[:N_Z] = z
    accel_constants(zw)
    for f, skip in ((accel, ()), (accel_nc, CRANK_COLUMNS)):
        oa, ja = np.zeros(4), np.full(2 * N_Z, np.nan)
        f(zw, oa, ja)
        # theta3dd, x4dd, F and M2 (M2's value only: the crank's work)
        np.testing.assert_allclose(oa, o[[0, 1, 5, 4]], rtol=1e-13, atol=1e-13 * abs(o).max())
        keep = [j for j in range(N_Z) if j not in skip]
        ref = flat.reshape(8, N_Z)[:2, keep]
        np.testing.assert_allclose(ja.reshape(2, N_Z)[:, keep], ref, rtol=1e-12,
                                   atol=1e-13 * np.abs(ref).max())
        assert np.isnan(ja.reshape(2, N_Z)[:, list(skip)]).all()   # left as they were


@pytest.mark.parametrize("branch,outputs,outputs_nc", [
    (contact_branch, contact_outputs, contact_outputs_nc),
    (free_branch, free_outputs, free_outputs_nc)])
def test_outputs_at_given_acceleration_chain_to_the_full_branch(paper, branch, outputs,
                                                                outputs_nc):
    """The *_outputs functions (theta3dd an input) give the full branch's F12x, F12y, M2 and
    F, and their Jacobian chained through theta3dd's row gives the full branch's rows:
    d o/d z_j = (d o/d z_j)|theta3dd + (d o/d theta3dd) (d theta3dd/d z_j)."""
    ts, ys, ms, *_ = reduced.run(paper, 2)
    i = 3 * len(ts) // 4
    z = _z(paper, ts[i], ys[i], ms[i, 1])
    o, flat = np.zeros(8), np.zeros(8 * N_Z)
    branch(z, o, flat)
    full = flat.reshape(8, N_Z)
    zo = np.append(z, o[0])
    assert len(zo) == N_ZO
    oo, jo = np.zeros(4), np.zeros(4 * N_ZO)
    outputs(zo, oo, jo)
    jo = jo.reshape(4, N_ZO)
    # the _nc variant: the same, without the crank-angle columns (left as they were)
    oo_nc, jo_nc = np.zeros(4), np.full(4 * N_ZO, np.nan)
    outputs_nc(zo, oo_nc, jo_nc)
    jo_nc = jo_nc.reshape(4, N_ZO)
    keep = [j for j in range(N_ZO) if j not in CRANK_COLUMNS]
    np.testing.assert_array_equal(oo_nc, oo)
    np.testing.assert_array_equal(jo_nc[:, keep], jo[:, keep])
    assert np.isnan(jo_nc[:, list(CRANK_COLUMNS)]).all()
    rows = [2, 3, 4, 5]    # F12x, F12y, M2, F of the full branch
    # different expressions round differently: the penetration (~1e-6 m) is a difference of
    # coordinates of size L2 + L3, relative round-off ~4e-11 (as in the test above)
    np.testing.assert_allclose(oo, o[rows], rtol=1e-9, atol=1e-12 * abs(o).max())
    chained = jo[:, :N_Z] + np.outer(jo[:, N_Z], full[0])
    np.testing.assert_allclose(chained, full[rows], rtol=1e-9,
                               atol=1e-12 * np.abs(full[rows]).max())
    assert np.abs(jo[:, N_Z]).max() > 0.0 and np.abs(jo[3, N_Z]) == 0.0   # F: not through it


def test_ddm_trajectory_equals_the_plain_simulation(paper, rev4, ddm):
    """The nominal trajectory of a DDM run (state integrated with its sensitivities by DOP853,
    outputs recorded by the sensitivity monitor, crank work from the generated M2) equals
    the plain model's (dopri5, hand-written dynamics) at the same output times."""
    plain = simulate(paper, 4, t_eval=rev4, rtol=1e-10)
    tr = ddm.trajectory
    np.testing.assert_array_equal(tr.t, plain.t)
    for name in ("base_force", "crank_moment", "contact_force", "slider_position",
                 "slider_velocity", "slider_acceleration", "coupler_angle", "crank_work"):
        a, b = getattr(tr, name), getattr(plain, name)
        err = np.max(np.abs(a - b)) / np.max(np.abs(b))
        assert err < 1e-6, (name, err)
    np.testing.assert_array_equal(tr.contact_phase, plain.contact_phase)


def test_norm_maxima_equals_numpy():
    """The compiled growth diagnostic against the same maxima written with numpy, with a
    parameter that combines two directions and one with no direction."""
    from mbs_clearance.ddm import norm_maxima

    rng = np.random.default_rng(1)
    nb, npar, n = 3, 5, 40
    ys = rng.normal(size=(n, 4 + 4 * nb + 1))
    coeffs = np.zeros((nb, npar))
    coeffs[0, 0] = coeffs[1, 1] = coeffs[2, 2] = 1.0
    coeffs[:2, 3] = [0.5, -2.0]          # parameter 4 zero: no direction
    weights = rng.uniform(0.5, 2.0, 4 * npar)
    lo, hi = np.array([0, 10, 25]), np.array([11, 25, 40])
    s = np.einsum("nbj,bk->nkj", ys[:, 4:4 + 4 * nb].reshape(n, nb, 4), coeffs)
    norms = np.sqrt((weights.reshape(npar, 4)[None] * s**2).sum(axis=2))
    ref = np.array([norms[a:b].max(axis=0) for a, b in zip(lo, hi)])
    np.testing.assert_allclose(norm_maxima(ys, coeffs, weights, lo, hi), ref, rtol=1e-13)


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
    integrated direction; crank_inertia (no effect at constant crank speed) none. The
    compressed result equals a run that integrates every parameter separately."""
    assert ddm.stats["directions"] == 7
    names = ["youngs_modulus", "crank_inertia", "poisson_ratio", "contact_stiffness",
             "journal_radius", "bearing_radius"]
    s = sensitivities(paper, names, t_eval=rev4, rtol=1e-10)
    # K alone; c and K by R_J; R_B moves c and K too: a combination of the two
    assert s.stats["directions"] == 2
    assert np.all(s.base_force_magnitude[:, 1] == 0.0)
    monkeypatch.setattr(sens_module, "independent_directions",
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
    the chain matrix and the Jacobian's K column."""
    monkeypatch.setattr(sens_module, "independent_directions",
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
    from mbs_clearance.sensitivity import load_sensitivities

    back = load_sensitivities(ddm.save(tmp_path / "s.npz"))
    assert back.parameters == ddm.parameters and back.method == "ddm"
    np.testing.assert_array_equal(back.normalized, ddm.normalized)
    np.testing.assert_array_equal(back.growth, ddm.growth)
    with pytest.raises(ValueError, match="cannot read sensitivities file"):
        load_sensitivities(tmp_path / "missing.npz")
