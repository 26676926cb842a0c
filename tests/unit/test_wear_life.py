"""The wear life on the reduced model (`studies.wear`): Archard's volume against the
integrator's own friction work, the volume the profile gained against the volume worn, the
life's convergence as its intervals shrink, and the command line."""

import dataclasses
import json

import numpy as np
import pytest

from mbs_clearance import cli
from mbs_clearance.model.cases import paper_slider_crank_wear
from mbs_clearance.solve.simulate import simulate
from mbs_clearance.studies.wear import WearLife, cycle_wear, load_wear, wear_life


@pytest.fixture(scope="module")
def case():
    return paper_slider_crank_wear()


def test_the_worn_volume_is_archards_integral_of_the_friction_work(case):
    # Coulomb friction dissipates mu F |v| (regularised below friction_v0 = 1e-4 m/s), so the
    # integrator's friction work over a revolution, divided by mu, is the integral of F |v|
    # that Archard's volume is k/H times: an independent quadrature (an integrated state)
    cj = case.clearance_joints[0]
    k = cj.wear_coefficient
    cw = cycle_wear(case, 0, k, settle=3, record=1, samples=2048, rtol=1e-10)
    period = 2 * np.pi / case.drive.speed
    tr = simulate(case, 4, rtol=1e-10)
    start = np.searchsorted(tr.t, 3 * period)
    work = tr.friction_work[-1] - np.interp(3 * period, tr.t, tr.friction_work)
    assert start < len(tr.t)
    assert cw.volume == pytest.approx(k * work / cj.friction_coefficient, rel=1e-5)
    # the depth in the cells holds the same volume
    cell = 2 * np.pi / len(cw.depth)
    assert np.sum(cw.depth * cj.bearing_length * cj.bearing_radius * cell) == pytest.approx(
        cw.volume, rel=1e-12)
    # the wear sits where the coupler presses the slider: about its axis, both ways
    top = np.degrees(np.argsort(cw.depth)[-1] * cell)
    assert min(abs(top - 180.0), top, 360.0 - top) < 25.0


def test_a_life_converges_as_its_intervals_shrink_and_keeps_its_volume(case):
    lives = [wear_life(case, 2e5, tolerance=tol, max_interval=1e5, samples=1024)
             for tol in (0.02, 0.005)]
    coarse, fine = lives
    # the profile moves by less than the coarse life's own estimate when refined
    assert np.max(np.abs(coarse.profiles[-1] - fine.profiles[-1])) <= coarse.error_estimate
    # the volume the profile gained (the area between the profiles times the length) is
    # the volume worn, to the small-wear approximation (depth / radius)
    cj = case.clearance_joints[0]
    for res in lives:
        theta = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
        from mbs_clearance.model.profile import BearingProfile

        area = [np.mean(BearingProfile(r).radius(theta) ** 2) * np.pi for r in
                (res.profiles[0], res.profiles[-1])]
        gained = cj.bearing_length * (area[1] - area[0])
        assert gained == pytest.approx(res.wear_volume[-1], rel=1e-3)
    # at a nearly constant load the volume grows linearly with the cycles
    rate = fine.wear_volume[1:] / fine.cycles[1:]
    assert np.ptp(rate) < 0.01 * rate.mean()


def test_the_wear_command_prints_the_life_and_writes_what_it_says(tmp_path, capsys):
    out = tmp_path / "life.json"
    code = cli.main(["wear", "--cycles", "20000", "--limit", "20kN", "--out", str(out),
                     "--set", "wear_coefficient=1e-15"])
    assert code == 0
    text = capsys.readouterr().out
    assert "wear of clearance joint 'coupler_slider' of paper_slider_crank_wear" in text
    assert "load limit 20000 N: not reached in 20000 cycles" in text
    res = load_wear(out)
    assert res.coefficient == 1e-15 and res.cycles[-1] == pytest.approx(20000)
    assert len(res.cycles) >= 21
    data = json.loads(out.read_text())
    assert data["kind"] == "wear life"
    # a second run may replace it without --force: the file is recognised as ours
    from mbs_clearance._io import file_is_ours

    assert file_is_ours(out, load_wear)


@pytest.mark.parametrize("argv, message", [
    (["wear", "--cycles", "0"], "argument --cycles: must be a finite number > 0"),
    (["wear", "--case", "four_bar", "--cycles", "10"], "wear_coefficient must be in"),
    (["wear", "--joint", "nope"], "joint must be one of the clearance joints"),
    (["wear", "--set", "wear_coefficient=-1"], "wear_coefficient must be in"),
])
def test_the_wear_command_refuses_bad_input_in_one_line(argv, message, capsys):
    try:
        code = cli.main(argv)
    except SystemExit as exc:           # argparse's own refusals
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


_CALLS = []


class _Recorded(WearLife):
    def __call__(self, values):
        y = super().__call__(values)
        _CALLS.append((dict(values), y))
        return y


def test_a_tolerance_study_takes_the_wear_life_as_its_output():
    from mbs_clearance.studies.tolerance import Uniform, tolerance_study

    _CALLS.clear()
    out = _Recorded(cycles=2e6, tolerance=0.05)
    res = tolerance_study({"wear_coefficient": Uniform(1e-16, 4e-16)}, output=out, sobol=0,
                          monte_carlo=3, seed=1, progress=False, executor="serial")
    y = np.asarray(res.monte_carlo["values"])
    assert len(y) == 3 and out.censored(y) == 0
    assert sorted(y) == sorted(v for _, v in _CALLS)
    # Archard: the depth grows as k/H times the cycles while the dynamics barely change, so
    # the cycles to twice the clearance scale as 1 / (k/H) (within the peaks' change, ~1 %)
    for values, life in _CALLS:
        assert life * values["wear_coefficient"] == pytest.approx(
            _CALLS[0][1] * _CALLS[0][0]["wear_coefficient"], rel=0.03)


def test_a_circular_profile_gives_the_papers_pinned_peak():
    # the paper case's default run (4 revolutions, rtol 1e-7) on a bearing_profile of 360
    # equal radii: the pinned 8291.958273534865 N of the circular joint (test_perf_counts)
    from mbs_clearance.model.cases import paper_slider_crank
    from mbs_clearance.solve import linkage_model as lm

    link = paper_slider_crank()
    cj = link.clearance_joints[0]
    circle = link.replace(clearance_joints=(
        dataclasses.replace(cj, bearing_profile=(cj.bearing_radius,) * 360),))
    traj = lm.simulate_linkage(circle, 4, rtol=1e-7)
    assert traj.peaks[-1] == pytest.approx(8291.958273534865, rel=1e-12)


def test_a_ga_lengthens_the_life_as_archard_says_it_should():
    # the bearing's length does not enter the dry joint's dynamics; it only spreads the worn
    # volume: the depth scales as 1 / L, so the life to twice the clearance as L (closed form)
    from mbs_clearance.studies.wear import optimize_wear_life

    worn = {"wear_coefficient": 2e-16}
    life = WearLife(overrides=tuple(worn.items()), cycles=3e6)
    short, long_ = (life({"bearing_length": v}) for v in (0.01, 0.02))
    assert long_ / short == pytest.approx(2.0, rel=0.01)
    opt = optimize_wear_life({"bearing_length": (0.005, 0.02)}, overrides=worn, cycles=3e6,
                             population=4, generations=2, seed=1)
    assert opt.life == pytest.approx(life(opt.best), rel=1e-12)
    assert not opt.censored and opt.best["bearing_length"] > 0.0125
    assert opt.history == sorted(opt.history)        # the elite is kept
    with pytest.raises(ValueError, match=r"genes\['bearing_length'\] must be \(low, high\)"):
        optimize_wear_life({"bearing_length": (0.02, 0.01)})
