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
