"""Trajectory: save/load round trips, windows, errors."""

from pathlib import Path

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


def test_paper_names_are_the_description_s_series(traj, paper):
    """The paper's names read the generic series of the description's coordinates: the
    SliderCrank's run and its description's run (the same model from the same start) give
    equal arrays under both names, the property being the generic array itself; the slider
    and coupler follow the ideal mechanism's closed form within the clearance (a swapped
    or misnamed coordinate would not)."""
    from mbs_clearance.backends.ideal import ideal_outputs
    from mbs_clearance.solve import reduced
    from mbs_clearance.solve.trajectory import PAPER_SERIES

    desc = simulate(reduced.linkage_of(paper), 2, start=reduced.centred_start(paper))
    assert desc.linkage is not None and traj.linkage is None
    for name, (_, kind, coordinate) in PAPER_SERIES.items():
        assert getattr(traj, name) is getattr(traj, kind)[coordinate]
        np.testing.assert_array_equal(getattr(traj, name), getattr(desc, kind)[coordinate])
        np.testing.assert_array_equal(getattr(desc, name), getattr(traj, name))
    # the journal's offset e from the bearing moves the slider by e_x + tan(theta3) e_y and
    # turns the coupler by e_y / (L3 cos theta3) to first order (|tan theta3| <= 0.46)
    ideal = ideal_outputs(paper, traj.t)
    e = np.max(np.hypot(*traj.eccentricity.T))
    L2, L3 = paper.crank_length, paper.coupler_length
    reach = np.sqrt(L3**2 - L2**2)
    assert 0.9 * paper.clearance < e
    assert np.max(np.abs(traj.slider_position - ideal["x4"])) <= 1.01 * e * (1 + L2 / reach)
    assert np.max(np.abs(traj.coupler_angle - ideal["theta3"])) <= 1.01 * e / reach


def test_ideal_run_paper_names_are_derivatives_of_each_other(paper):
    """The ideal-joint run's paper names by their description's coordinates: each rate the
    time derivative of its coordinate (central differences on 3600 samples per revolution),
    the slider's acceleration that of its velocity."""
    tr = simulate(paper, 1, backend="ideal")
    assert tr.joints == ("coupler_slider",)
    assert tuple(tr.coordinates) == ("coupler.angle", "slider_guide.s")
    for rate, of in (("slider_velocity", "slider_position"),
                     ("slider_acceleration", "slider_velocity"),
                     ("coupler_rate", "coupler_angle")):
        d = np.gradient(getattr(tr, of), tr.t)[1:-1]
        ref = getattr(tr, rate)[1:-1]
        assert np.max(np.abs(d - ref)) < 1e-3 * np.max(np.abs(ref)), rate


def test_a_linkage_without_the_coordinate_raises_the_paper_name():
    """Where the description has the coordinate the paper's name reads it (the two-joint
    slider-crank's slider, the four-bar's coupler); where not, a clear AttributeError
    naming the linkage and its coordinates (hasattr is False)."""
    from mbs_clearance.model import cases

    two = simulate(cases.slider_crank_two_clearances(), 1, backend="ideal",
                   samples_per_revolution=72)
    assert two.slider_velocity is two.rates["slider_guide.s"]
    fb = simulate(cases.four_bar(), 1, backend="ideal", samples_per_revolution=72)
    assert fb.coupler_rate is fb.rates["coupler.angle"]
    for name in ("slider_position", "slider_velocity", "slider_acceleration"):
        assert not hasattr(fb, name)
        with pytest.raises(AttributeError, match=f"{name} is the series of the paper "
                           r"slider-crank's coordinate 'slider_guide.s', which linkage "
                           r"'four_bar' does not have \(its \w+: 'coupler.angle', "
                           r"'rocker.angle'\)"):
            getattr(fb, name)


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_ideal_run_save_load_keeps_every_series(tmp_path, paper, suffix):
    """A run without reactions (ideal joints): the paper's columns and the coordinates come
    back equal, under both names."""
    tr = simulate(paper, 1, backend="ideal", samples_per_revolution=72)
    back = load_trajectory(tr.save(tmp_path / f"ideal{suffix}"))
    assert back.joints == tr.joints and back.reactions is None
    for kind in ("coordinates", "rates", "accelerations"):
        assert getattr(back, kind).keys() == getattr(tr, kind).keys()
        for c, v in getattr(tr, kind).items():
            np.testing.assert_array_equal(getattr(back, kind)[c], v)
    np.testing.assert_array_equal(back.slider_acceleration, tr.slider_acceleration)


def _columns_of(path):
    """The named columns of a saved file, read without the package."""
    if path.suffix == ".npz":
        with np.load(path) as data:
            return {k: data[k] for k in data.files if k != "meta"}
    with open(path) as fh:
        fh.readline()
        header = fh.readline().strip().split(",")
    table = np.loadtxt(path, delimiter=",", skiprows=2)
    return {name.split("[")[0]: table[:, k] for k, name in enumerate(header)}


@pytest.mark.parametrize("name", ["reduced.npz", "reduced.csv", "ideal.npz", "ideal.csv"])
def test_files_of_the_earlier_format_load(tmp_path, paper, name):
    """SliderCrank trajectories saved by the earlier release (the paper's series as their
    own columns; the reduced model's with the description's beside them, the ideal run's
    without): they load, their paper names equal the file's columns and a new run of the
    same case, and a loaded file saves and loads again."""
    from mbs_clearance.solve.trajectory import PAPER_SERIES

    path = Path(__file__).parents[1] / "data" / f"trajectory_paper_{name}"
    tr = load_trajectory(path)
    cols = _columns_of(path)
    assert tr.mechanism == paper and tr.joints == ("coupler_slider",)
    for series in PAPER_SERIES:
        np.testing.assert_array_equal(getattr(tr, series), cols[series])
    if tr.backend == "ideal":
        new = simulate(paper, 1, backend="ideal", samples_per_revolution=24)
        # an earlier ideal file has no coupler acceleration: what it stored, no more
        assert tuple(tr.accelerations) == ("slider_guide.s",)
    else:
        new = simulate(paper, 1, t_eval=tr.t)
        assert tr.reactions.keys() == {"crank_pivot", "slider_guide"}
    for series in ("base_force", *PAPER_SERIES):
        np.testing.assert_allclose(getattr(tr, series), getattr(new, series), rtol=1e-9,
                                   atol=1e-9 * np.max(np.abs(getattr(new, series))))
    again = load_trajectory(tr.save(tmp_path / path.name))
    for series in PAPER_SERIES:
        np.testing.assert_array_equal(getattr(again, series), getattr(tr, series))


def test_a_file_whose_two_names_disagree_is_refused(tmp_path):
    """A reduced-model file holds the slider's position under both names: a file where they
    differ is refused, naming the column."""
    path = Path(__file__).parents[1] / "data" / "trajectory_paper_reduced.npz"
    with np.load(path) as data:
        cols = {k: data[k] for k in data.files}
    cols["slider_position"] = cols["slider_position"] + 1e-9
    bad = tmp_path / "bad.npz"
    np.savez(bad, **cols)
    with pytest.raises(ValueError, match="column 'slider_position' differs from the "
                                         "coordinates column of 'slider_guide.s'"):
        load_trajectory(bad)


def test_exudyn_run_of_the_slider_crank_keeps_the_description_s_series(traj, paper):
    """Exudyn's run of the SliderCrank keeps its description's generic series: the paper's
    names read its coordinates, the crank pivot's reaction is base_force, the shaking force
    the reactions' sum, which the comparison with the reduced model's takes like for like
    (measured 8e-5 rms apart; against |F12| in its place 6e-3)."""
    from validation.compare import compare

    ex = simulate(paper, 2, backend="exudyn")
    assert ex.joints == ("coupler_slider",) and ex.linkage is None
    assert ex.slider_position is ex.coordinates["slider_guide.s"]
    np.testing.assert_array_equal(ex.reactions["crank_pivot"], ex.base_force)
    scale = np.max(np.abs(ex.shaking_force))
    assert np.max(np.abs(ex.shaking_force - sum(ex.reactions.values()))) <= 1e-9 * scale
    for rev in compare(traj, ex).revolutions:
        assert abs(rev.shaking_rms_rel_diff) < 1e-3, rev
