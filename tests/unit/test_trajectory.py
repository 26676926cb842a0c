"""Trajectory: save/load round trips, windows, errors."""

import numpy as np
import pytest

from mbs_clearance import Trajectory, load_trajectory, simulate


@pytest.fixture(scope="module")
def traj(paper):
    return simulate(paper, 2)


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_save_load_roundtrip(tmp_path, traj, suffix):
    path = traj.save(tmp_path / f"traj{suffix}")
    back = load_trajectory(path)
    assert back.mechanism == traj.mechanism and back.backend == traj.backend
    for name in ("t", "base_force", "eccentricity", "contact_phase", "crank_work"):
        np.testing.assert_array_equal(getattr(back, name), getattr(traj, name))
    assert back.max_base_force(2) == traj.max_base_force(2)
    assert Trajectory.load(path).stats == back.stats
    # the description's generic series come back too, and the paper's names stay their
    # aliases: the crank pivot's reaction is the base force
    assert back.joints == traj.joints == ("coupler_slider",)
    assert set(back.reactions) == set(traj.reactions) and set(back.coordinates) == set(
        traj.coordinates)
    for g in traj.reactions:
        np.testing.assert_array_equal(back.reactions[g], traj.reactions[g])
    for c in traj.coordinates:
        for kind in ("coordinates", "rates", "accelerations"):
            np.testing.assert_array_equal(getattr(back, kind)[c], getattr(traj, kind)[c])
    np.testing.assert_array_equal(back.shaking_force, traj.shaking_force)
    np.testing.assert_array_equal(back.reactions["crank_pivot"], back.base_force)


def test_revolution_windows(traj, paper):
    assert traj.revolutions == 2
    t_a, t_b = traj.revolution_window(2)
    assert t_a == pytest.approx(paper.period) and t_b == pytest.approx(2 * paper.period)
    with pytest.raises(ValueError, match="revolution must be between 1 and 2"):
        traj.max_base_force(3)
    with pytest.raises(ValueError, match="revolution must be an integer >= 1"):
        traj.max_base_force(0)


def test_unreadable_files(tmp_path, traj):
    with pytest.raises(ValueError, match="must end in .npz or .csv"):
        traj.save(tmp_path / "x.txt")
    with pytest.raises(ValueError, match="cannot read trajectory file"):
        load_trajectory(tmp_path / "missing.npz")
    bad = tmp_path / "bad.csv"
    bad.write_text("garbage\n1,2,3\n")
    with pytest.raises(ValueError, match="cannot read trajectory file"):
        load_trajectory(bad)


def test_linkage_series_are_the_model_outputs_and_boundaries_interpolate_them():
    """A two-joint linkage's Trajectory against the generated model's outputs evaluated
    again at the recorded states (numpy's column indexing): every per-joint series, the
    reactions, the shaking force, the eccentricity's joint and axis order; the revolution
    boundary states against np.interp over the whole series."""
    from mbs_clearance.model import cases
    from mbs_clearance.solve.linkage_model import load_model, pack_parameters
    from mbs_clearance.solve.trajectory import boundary_states

    lk = cases.slider_crank_two_clearances()
    tr = simulate(lk, 3)
    model = load_model(lk)
    p = pack_parameters(lk, model)
    ys = np.column_stack([*tr.coordinates.values(), *tr.rates.values(), tr.crank_work])
    ms = np.zeros((len(tr.t), model.N_MEM))
    ms[:, 0::2] = tr.contact_phase
    # the impact velocities enter the contact force only: compare that series by itself
    outs = model.outputs(tr.t, np.ascontiguousarray(ys), ms, p)
    col = {c: i for i, c in enumerate(model.OUT_COLUMNS)}
    for k, j in enumerate(model.JOINTS):
        np.testing.assert_array_equal(tr.penetration[:, k], outs[:, col[f"{j}.penetration"]])
        for a, axis in enumerate("xy"):
            np.testing.assert_array_equal(tr.eccentricity[:, k, a],
                                          outs[:, col[f"{j}.ecc_{axis}"]])
        assert tr.contact_force.shape == tr.penetration.shape == (len(tr.t), 2)
    for f in tr.reactions.values():
        assert f.flags.c_contiguous and f.shape == (len(tr.t), 2)
    np.testing.assert_array_equal(tr.base_force, tr.reactions[model.MONITOR_JOINT])
    assert np.max(np.abs(tr.shaking_force - sum(tr.reactions.values()))) <= 1e-9 * np.max(
        np.abs(tr.shaking_force))

    got = boundary_states(tr)
    times = np.arange(1, 4) * lk.period
    c, w = lk.min_clearance, lk.drive.speed
    cols = [tr.eccentricity[:, k, i] / j.clearance
            for k, j in enumerate(lk.clearance_joints) for i in range(2)]
    cols += [v * (lk.length_scale if name.endswith(".angle") else 1.0) / (w * c)
             for name, v in tr.rates.items()]
    want = np.column_stack([np.interp(times, tr.t, x) for x in cols])
    np.testing.assert_array_equal(got, want)
