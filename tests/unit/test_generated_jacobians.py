"""The generated Jacobians (generate/jacobians.py) against central finite differences of the
generated plain kernels (`outputs`, `prepare`), on every named case, in free flight and in
contact, at states with the journals off-centre."""

import numpy as np
import pytest

from mbs_clearance.generate import load_model
from mbs_clearance.model import cases
from mbs_clearance.solve.linkage_model import initial_state, pack_parameters

_LUBRICATED = ("paper_slider_crank_lubricated", "paper_slider_crank_lubricated+fade",
               "paper_slider_crank_lubricated+long")
CASES = ("paper_slider_crank", "slider_crank_two_clearances", "four_bar",
         "paper_slider_crank+coulomb", "paper_slider_crank+ambrosio",
         "paper_slider_crank+stribeck", "paper_slider_crank+general",
         *_LUBRICATED)
# the four-bar at the 0.1 mm clearance where this test was measured (the case's default is
# 0.01 mm, where the free-flight difference quotients of the point coordinates, 1.2e-6
# relative off, were not re-examined)
FADE_ENDS = {"film_fade_start": 0.3, "film_fade_end": 0.7}
OVERRIDES = {"four_bar": {"clearance": 1e-4},
             # friction: thresholds at the scale of the slip velocity (~1 m/s
             # here) so that the laws' slopes in it are exercised
             "paper_slider_crank+coulomb": {"friction_law": "coulomb",
                                            "friction_coefficient": 0.3, "friction_v0": 0.5,
                                            "friction_v1": 1.0},
             "paper_slider_crank+ambrosio": {"friction_law": "ambrosio",
                                             "friction_coefficient": 0.3, "friction_v0": 0.01,
                                             "friction_v1": 20.0},
             "paper_slider_crank+stribeck": {"friction_law": "stribeck",
                                             "friction_coefficient": 0.3, "friction_v0": 0.5,
                                             "friction_v1": 20.0,
                                             "friction_static_coefficient": 0.45,
                                             "friction_stribeck_velocity": 1.0},
             # the long film (its partials with its lobes' ends moving), inside the fade
             "paper_slider_crank_lubricated+long": {"lubrication": "long", **FADE_ENDS}}


#: the lubricated case with its film's fade over eps 0.3-0.7: the "free" states below (the
#: journal half a clearance off-centre) are inside the fade, its ends' columns exercised
FADE = FADE_ENDS


def _case(case):
    """(linkage, model) of a case name: the module specialised on the linkage's zero-valued
    geometric parameters, or ("+general") the general one, whose Jacobian has their columns."""
    linkage = getattr(cases, case.partition("+")[0])(
        **(FADE if case.endswith("+fade") else OVERRIDES.get(case, {})))
    return linkage, load_model(linkage, specialise=not case.endswith("+general"))


def _state(linkage, model, p, t, penetration, rng):
    """A state at time t with every journal off-centre by (1 + penetration) clearances in a
    random direction (closure solved by Newton), rates from the velocity constraints plus a
    small random part."""
    y = initial_state(linkage, model, p, t0=t)
    n = model.N_Q
    q = y[:n].copy()
    target = []
    for j in linkage.clearance_joints:
        a = rng.uniform(0, 2 * np.pi)
        target += [(1 + penetration) * j.clearance * np.cos(a),
                   (1 + penetration) * j.clearance * np.sin(a)]
    target = np.array(target)
    for _ in range(30):
        res = model.closure(t, q, p) - target
        q -= np.linalg.lstsq(model.closure_jacobian(t, q, p), res, rcond=None)[0]
    assert np.max(np.abs(model.closure(t, q, p) - target)) < 1e-12 * linkage.length_scale
    qd = y[n:2 * n] * (1 + 1e-3 * rng.standard_normal(n))
    return np.concatenate([q, qd, [0.0]])


def _outputs(model, t, y, p):
    ms = p[model.MEM_START:model.MEM_START + model.N_MEM][None, :].copy()
    return model.outputs(np.array([t]), y[None, :].copy(), ms, p)[0]


def _fd_column(model, t, y, p, col, h):
    """Central differences with Richardson extrapolation (error O(h^4)) of the outputs along
    z column col."""
    n2 = 2 * model.N_Q

    def at(step):
        tt, yy, pp = t, y.copy(), p.copy()
        if col == 0:
            tt = t + step
        elif col <= n2:
            yy[col - 1] += step
        else:
            pp[col - 1 - n2] += step
            model.prepare(pp)
        return _outputs(model, tt, yy, pp)

    d1 = (at(h) - at(-h)) / (2 * h)
    d2 = (at(h / 2) - at(-h / 2)) / h
    return (4 * d2 - d1) / 3


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("mode", ["free", "contact"])
def test_jacobian_matches_finite_differences(case, mode):
    """Every output column's derivative along every column of z (time, coordinates, rates,
    every parameter, the impact-velocity memory) equals central finite differences of the
    plain generated `outputs`; the values equal `outputs` to round-off. (The columns of the
    parameters a module is specialised on, which must stay zero, are zero.)"""
    check_against_differences(*_case(case), mode)


def check_against_differences(linkage, model, mode):
    """`test_jacobian_matches_finite_differences` of a loaded (compiled) model in `mode`
    ("free" or "contact")."""
    p = pack_parameters(linkage, model)
    rng = np.random.default_rng(7)
    t = 0.37 * linkage.period
    pen = 0.02 if mode == "contact" else -0.5
    y = _state(linkage, model, p, t, pen, rng)
    for j in range(model.N_EVENTS):
        p[model.MEM_START + 2 * j] = 1.0 if mode == "contact" else 0.0
        p[model.MEM_START + 2 * j + 1] = 0.05
    plain = _outputs(model, t, y, p)
    if mode == "contact":
        forces = plain[[model.OUT_COLUMNS.index(f"{j}.contact_force") for j in model.JOINTS]]
        assert np.all(forces > 0)
        friction = [model.OUT_COLUMNS.index(f"{j}.friction_force")
                    for j in model.FRICTION_JOINTS]
        assert np.all(plain[friction] != 0.0)       # the friction rows are exercised
    jac = model.jacobian_matrix(t, y, p, True)
    n_out = model.N_OUT
    # (a penetration is a difference of positions: its round-off relative to it is about
    # 1e-16 length_scale / penetration, 1e-10 here)
    np.testing.assert_allclose(jac[:n_out, -1], plain, rtol=1e-9,
                               atol=1e-12 * np.max(np.abs(plain)))
    z = np.concatenate([[t], y[:2 * model.N_Q], p[:model.CONST_START]])
    clearance = min(j.clearance for j in linkage.clearance_joints)
    pen_rows = [model.OUT_COLUMNS.index(f"{j}.penetration") for j in model.JOINTS]
    gap = min(np.min(np.abs(plain[pen_rows])), clearance)
    forces = [r for r, c in enumerate(model.OUT_COLUMNS)
              if c.endswith(("contact_force", "_x", "_y")) and ".ecc_" not in c]
    for col, name in enumerate(model.Z_NAMES):
        if name.endswith((".mode", ".contact_model", ".friction_law")) or \
                name in model.ZERO_PARAMETERS:
            # discrete: no derivative; specialised on zero: not in the module's equations
            assert np.all(jac[:n_out, col] == 0.0), name
            continue
        # a step that moves every penetration by at most 1 % of the smallest one (a force's
        # Taylor series converges within the penetration) and the value by 1e-6
        slope = np.max(np.abs(jac[pen_rows, col]))
        h = 1e-6 * max(abs(z[col]), 1e-3)
        if slope > 0:
            h = min(h, 1e-2 * gap / slope)
        fd = _fd_column(model, t, y, p, col, h)
        # the finite differences' own error (truncation O(h^4), round-off ~ 1 / h, large
        # where a penetration is the small difference of positions): their spread between
        # the steps h and h / 3
        spread = np.abs(fd - _fd_column(model, t, y, p, col, h / 3))
        err = np.abs(jac[:n_out, col] - fd)
        # (and the round-off of the analytic sums: 1e-13 of the row's largest entry, of all
        # force rows' for a force: a guide's reaction along it is a cancelling sum)
        floor = 1e-13 * np.abs(jac[:n_out, :-1]).max(axis=1)
        floor[forces] = floor[forces].max()
        bad = err > 1e-6 * np.abs(fd) + 10 * spread + floor
        assert not bad.any(), (name, [model.OUT_COLUMNS[r] for r in np.flatnonzero(bad)],
                               jac[:n_out, col][bad], fd[bad])


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("mode", ["free", "contact"])
def test_tangent_is_jacobian_times_seeds(case, mode):
    """The generated forward-mode kernel `tangent` (what the sensitivity equations evaluate)
    equals the full Jacobian times the seed directions to round-off, on every row (outputs,
    the joints' extra rows, friction), for random dense seeds and for unit seeds (the
    Jacobian's own columns); the value column equals the Jacobian's."""
    linkage, model = _case(case)
    p = pack_parameters(linkage, model)
    rng = np.random.default_rng(11)
    t = 0.29 * linkage.period
    y = _state(linkage, model, p, t, 0.02 if mode == "contact" else -0.5, rng)
    for j in range(model.N_EVENTS):
        p[model.MEM_START + 2 * j] = 1.0 if mode == "contact" else 0.0
        p[model.MEM_START + 2 * j + 1] = 0.05
    for full in (False, True):
        jac = model.jacobian_matrix(t, y, p, full)
        # each column of z scaled by its natural size (a parameter by its value), so every
        # column contributes to the product
        z = np.concatenate([[t], y[:2 * model.N_Q], p[:model.CONST_START]])
        scale = np.where(np.abs(z) > 0, np.abs(z), 1.0)
        seeds = rng.standard_normal((5, model.N_Z)) * scale[None, :]
        unit = np.eye(model.N_Z)[[0, 1, model.N_Z - 1]]
        for dz in (seeds, unit):
            tan = model.tangent_matrix(t, y, p, np.ascontiguousarray(dz), full)
            ref = jac[:, :-1] @ dz.T
            # the rows a call fills (without `full`: the joints' rows, the accelerations,
            # the drive moment's value)
            rows = np.arange(model.N_JROWS) if full else np.array(
                [r for r in range(model.N_JROWS) if np.any(jac[r, :-1] != 0.0)])
            # round-off: 1e-13 of each row's largest term |J_rk dz_dk|, of all force rows'
            # for a force (a guide's reaction along it is a cancelling sum of them)
            terms = (np.abs(jac[:, :-1])[:, None, :] * np.abs(dz)[None, :, :]).max(axis=2)
            forces = [r for r, c in enumerate(model.OUT_COLUMNS)
                      if c.endswith(("contact_force", "_x", "_y")) and ".ecc_" not in c]
            terms[forces] = terms[forces].max(axis=0)
            np.testing.assert_array_less(np.abs(tan[rows, :-1] - ref[rows]),
                                         1e-13 * terms[rows] + 1e-300)
            np.testing.assert_array_equal(tan[rows, -1], jac[rows, -1])


def _corner_state(off, tilt, across=0.02):
    """A state of the translational-clearance slider-crank with the slider's centre `off`
    across the guide and tilted by `tilt`, the crank at 0.6 rad and turning at 150 rad/s,
    the coupler's rate nearly cancelling the slider's motion across the guide (a slow
    approach at `across` of the crank's speed across the guide: the contact law's force
    stays positive) and the slider turning slowly."""
    L1, L2 = 0.153, 0.306
    th1 = 0.6
    th2 = np.arcsin((off - L1 * np.sin(th1)) / L2)
    w2 = -L1 * np.cos(th1) * 150.0 / (L2 * np.cos(th2))
    return np.array([th1, th2, tilt, 150.0, (1.0 - across) * w2, 0.3, 0.0])


@pytest.mark.parametrize("corners", [("front_top",), ("front_top", "rear_top"),
                                     ("front_top", "rear_bottom")])
def test_corner_jacobian_matches_finite_differences(corners):
    """The translational clearance joint's corners (normal force of the contact law, Coulomb
    friction regularised with a slope at the slip velocity's scale): every output's
    derivative along every column of z equals central differences of the plain `outputs`,
    with one corner in contact (tilted slider), two on one side (flat) and two opposite
    (tilted across the guide); `tangent` equals the Jacobian times random seeds."""
    from scipy.optimize import brentq

    linkage = cases.flores_translational_slider_crank(friction_coefficient=0.3,
                                                      friction_v0=0.5, friction_v1=1.0)
    model = load_model(linkage)
    p = pack_parameters(linkage, model)
    a, b, c, pen = 0.05, 0.025, 1e-3, 2e-5
    if corners == ("front_top", "rear_top"):
        y = _corner_state(c + pen, 0.0)
    else:
        # the front top corner pen deep: a sin(tilt) + b cos(tilt) = b + c + pen (+ the
        # centre's offset for one corner only, so the rear bottom one stays clear)
        off = -pen / 2 if len(corners) == 1 else 0.0
        tilt = brentq(lambda f: a * np.sin(f) + b * np.cos(f) - b - c - pen, 0.0, 0.1)
        y = _corner_state(off, tilt, 0.02 if len(corners) == 1 else 0.0)
    names = [f"guide.{k}" for k in corners]
    for j, name in enumerate(model.JOINTS):
        p[model.MEM_START + 2 * j] = 1.0 if name in names else 0.0
        p[model.MEM_START + 2 * j + 1] = 0.5
    t = 0.01
    plain = _outputs(model, t, y, p)
    col = model.OUT_COLUMNS.index
    assert all(plain[col(f"{n}.contact_force")] > 0 for n in names)
    assert all(plain[col(f"{n}.friction_force")] != 0 for n in names)
    jac = model.jacobian_matrix(t, y, p, True)
    n_out = model.N_OUT
    np.testing.assert_allclose(jac[:n_out, -1], plain, rtol=1e-9,
                               atol=1e-12 * np.max(np.abs(plain)))
    z = np.concatenate([[t], y[:2 * model.N_Q], p[:model.CONST_START]])
    pen_rows = [col(f"{j}.penetration") for j in model.JOINTS]
    for k, name in enumerate(model.Z_NAMES):
        if name.endswith((".mode", ".contact_model", ".friction_law")) or \
                name in model.ZERO_PARAMETERS:
            assert np.all(jac[:n_out, k] == 0.0), name
            continue
        # as the clearance joints' test: each penetration moves by at most 1 % of pen
        slope = np.max(np.abs(jac[pen_rows, k]))
        h = 1e-6 * max(abs(z[k]), 1e-3)
        if slope > 0:
            h = min(h, 1e-2 * pen / slope)
        fd = _fd_column(model, t, y, p, k, h)
        spread = np.abs(fd - _fd_column(model, t, y, p, k, h / 3))
        err = np.abs(jac[:n_out, k] - fd)
        floor = 1e-13 * np.abs(jac[:n_out, :-1]).max(axis=1)
        bad = err > 1e-6 * np.abs(fd) + 10 * spread + floor
        assert not bad.any(), (name, [model.OUT_COLUMNS[r] for r in np.flatnonzero(bad)],
                               jac[:n_out, k][bad], fd[bad])
    scale = np.where(np.abs(z) > 0, np.abs(z), 1.0)
    dz = np.random.default_rng(5).standard_normal((4, model.N_Z)) * scale[None, :]
    tan = model.tangent_matrix(t, y, p, np.ascontiguousarray(dz), True)
    ref = jac[:, :-1] @ dz.T
    terms = (np.abs(jac[:, :-1])[:, None, :] * np.abs(dz)[None, :, :]).max(axis=2)
    # round-off: 1e-13 of the largest term |J_rk dz_dk| of any row along the direction (the
    # accelerations and forces are sums over the corners' stiff terms)
    bound = np.broadcast_to(1e-13 * terms.max(axis=0) + 1e-300, ref.shape)
    np.testing.assert_array_less(np.abs(tan[:, :-1] - ref), bound)
    np.testing.assert_array_equal(tan[:, -1], jac[:, -1])
