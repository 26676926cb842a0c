"""`mbs-clearance animate` draws any Linkage from its description."""

import math

import numpy as np
import pytest

from mbs_clearance import simulate
from mbs_clearance.cli import main
from mbs_clearance.model import cases
from mbs_clearance.model.linkage import GROUND, Prismatic
from mbs_clearance.plotting import animate_mechanism, magnification, mechanism_frames
from mbs_clearance.units import number


class _Runs(dict):
    """One revolution of a named case (reduced model), run when first asked for."""

    def __missing__(self, name):
        self[name] = simulate(cases.CASES[name](), 1)
        return self[name]


@pytest.fixture(scope="module")
def runs():
    return _Runs()


#: every named case with a drive (an animation shows drive revolutions)
CASE_NAMES = [n for n in sorted(cases.CASES) if cases.CASES[n]().drive is not None]


def _world(lk, fr, body, point, k):
    if body == GROUND:
        return np.asarray(lk.ground_points[point])
    names = list(next(b for b in lk.bodies if b.name == body).points)
    return fr.bodies[body][k, names.index(point)]


@pytest.mark.parametrize("name", CASE_NAMES)
def test_drawn_geometry_is_the_trajectory_s(name, runs):
    """The drawn journal's offset from its bearing is magnify x the trajectory's eccentricity
    (the generated model's output; the drawing takes the description's kinematics), every
    ideal joint's two drawn points coincide, sliders stay on their guides."""
    traj = runs[name]
    lk = traj.linkage
    fr = mechanism_frames(traj, frames=7)
    assert len(fr.t) == 7 and fr.revolution == 1
    # frames spread over the revolution (nearest recorded steps to uniform times)
    assert np.all(np.diff(fr.t) > 0) and fr.t[-1] - fr.t[0] > 0.9 * lk.period
    assert fr.magnify == pytest.approx(magnification(lk))
    for j, cj in enumerate(lk.clearance_joints):
        drawn = fr.journals[cj.name] - fr.bearings[cj.name]
        ecc = traj.eccentricity[fr.index, j]
        assert np.abs(ecc).max() > 0.2 * cj.clearance          # the journal has moved
        np.testing.assert_allclose(drawn, fr.magnify * ecc, rtol=0,
                                   atol=1e-7 * fr.magnify * cj.clearance)
        # the drawn gap at the wall (|e| = c) is magnify x c: drawn journal + gap = bearing
        assert fr.journal_radius[cj.name] + fr.magnify * cj.clearance == pytest.approx(
            fr.bearing_radius)
    for k in range(7):
        for jt in lk.joints:
            a = _world(lk, fr, jt.body_a, jt.point_a, k)
            b = _world(lk, fr, jt.body_b, jt.point_b, k)
            if isinstance(jt, Prismatic):
                ends = fr.guides[jt.name][k]
                u = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
                d = b - ends[0]
                assert abs(u[0] * d[1] - u[1] * d[0]) < 1e-12 * lk.length_scale
            else:
                assert np.abs(a - b).max() < 1e-12 * lk.length_scale
    # the driven body turns with the drive: its angle is speed t + initial angle
    drive = next(jt for jt in lk.joints if jt.name == lk.drive.joint)
    body = next(b for b in lk.bodies if b.name == drive.body_b)
    names = list(body.points)
    other = next(p for p in names if p != drive.point_b)
    arm = fr.bodies[body.name][:, names.index(other)] - fr.bodies[body.name][
        :, names.index(drive.point_b)]
    local = np.subtract(body.points[other], body.points[drive.point_b])
    phi = lk.drive.speed * fr.t + lk.drive.initial_angle + math.atan2(local[1], local[0])
    np.testing.assert_allclose(arm, np.linalg.norm(local) * np.column_stack(
        [np.cos(phi), np.sin(phi)]), atol=1e-12 * lk.length_scale)


def test_paper_case_drawn_as_the_closed_form_slider_crank(runs):
    """The paper's case: crank pin at L2 (cos, sin) of the crank angle, the slider on the x
    axis at its coordinate s (the description's geometry, checked against the paper's)."""
    traj = runs["paper_slider_crank"]
    fr = mechanism_frames(traj, frames=5)
    th = traj.crank_angle[fr.index]
    pin = fr.bodies["crank"][:, 1]
    np.testing.assert_allclose(pin, 0.05 * np.column_stack([np.cos(th), np.sin(th)]),
                               atol=1e-14)
    slider = fr.bodies["slider"][:, 0]
    np.testing.assert_allclose(slider[:, 0], traj.coordinates["slider_guide.s"][fr.index],
                               atol=1e-14)
    assert np.abs(slider[:, 1]).max() < 1e-15


def _moving_gif(path, n_frames: int) -> None:
    """`path` is a GIF of `n_frames` frames, wide enough to read, whose pictures differ."""
    from PIL import Image

    with Image.open(path) as image:
        assert image.n_frames == n_frames and image.width > 300
        frames = []
        for k in range(image.n_frames):
            image.seek(k)
            frames.append(np.asarray(image.convert("L"), dtype=float))
    assert np.abs(frames[1] - frames[0]).max() > 0       # the mechanism moves


@pytest.mark.parametrize("name", CASE_NAMES)
def test_each_named_case_animates(name, runs, tmp_path):
    _moving_gif(animate_mechanism(runs[name], tmp_path / "a.gif", frames=3, fps=5), 3)


def test_cli_animates_the_paper_slider_crank(tmp_path, capsys):
    """Without --case: the paper's SliderCrank, drawn from its case's description (the same
    drawing and magnification as --case paper_slider_crank)."""
    out = tmp_path / "anim"
    assert main(["animate", "--revolutions", "1", "--frames", "4", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    shown = number(magnification(cases.paper_slider_crank()), 3)
    assert (f"wrote {out / 'mechanism.gif'} (animation of slider-crank, revolution 1, journal "
            f"offsets drawn {shown} times their size)") in err
    _moving_gif(out / "mechanism.gif", 4)


def test_a_slider_crank_trajectory_is_drawn_as_its_case(tmp_path):
    """The paper's SliderCrank's trajectory and its case's give the same frames: the same
    coordinates through the same description (the slider a block on its guide)."""
    from mbs_clearance import SliderCrank

    a = mechanism_frames(simulate(SliderCrank(), 1, rtol=1e-8), frames=4)
    b = mechanism_frames(simulate(cases.paper_slider_crank(), 1, rtol=1e-8), frames=4)
    assert set(a.bodies) == set(b.bodies) == {"crank", "coupler", "slider"}
    assert set(a.guides) == {"slider_guide"}
    for name in a.bodies:
        np.testing.assert_allclose(a.bodies[name], b.bodies[name], rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.journals["coupler_slider"], b.journals["coupler_slider"],
                               rtol=0, atol=1e-12)


def test_bad_input_is_a_clear_error(runs, tmp_path):
    traj = runs["four_bar"]
    with pytest.raises(ValueError, match="revolution must be between 1 and 1"):
        mechanism_frames(traj, revolution=2)
    with pytest.raises(ValueError, match=r"magnify .* in \(0, "):
        mechanism_frames(traj, magnify=1e9)
    with pytest.raises(ValueError, match="frames"):
        mechanism_frames(traj, frames=1)
    with pytest.raises(ValueError, match=r"\.gif or \.mp4"):
        animate_mechanism(traj, tmp_path / "a.png")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("argv, message", [
    (["--case", "nope"], "argument --case: invalid choice: 'nope'"),
    (["--case", "four_bar", "--revolutions", "2", "--revolution", "3"],
     "--revolution must be between 1 and --revolutions (2); got 3"),
    (["--revolution", "0"], "argument --revolution: must be an integer >= 1; got 0"),
    (["--case", "four_bar", "--magnify", "1e9"], "magnify (magnification of the journals' "
                                                 "offsets) must be"),
    (["--magnify", "1e9"], "magnify (magnification of the journals' offsets) must be"),
    (["--case", "four_bar", "--set", "nope=1"], "nope"),
])
def test_cli_bad_input_is_one_line_before_any_run(argv, message, tmp_path, capsys,
                                                  monkeypatch):
    import importlib

    sim = importlib.import_module("mbs_clearance.solve.simulate")   # the module, not the function
    monkeypatch.setattr(sim, "simulate", lambda *a, **k: pytest.fail("ran"))
    with pytest.raises(SystemExit) as exc:
        main(["animate", *argv, "--out", str(tmp_path / "out")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "out").exists()


def test_cli_animates_a_case_and_says_the_magnification(tmp_path, capsys):
    out = tmp_path / "anim"
    assert main(["animate", "--case", "four_bar", "--revolutions", "1", "--frames", "3",
                 "--out", str(out)]) == 0
    err = capsys.readouterr().err
    lk = cases.four_bar()
    assert (f"wrote {out / 'mechanism.gif'} (animation of four_bar, revolution 1, journal "
            f"offsets drawn {number(magnification(lk), 3)} times their size)") in err
    _moving_gif(out / "mechanism.gif", 3)
