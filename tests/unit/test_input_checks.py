"""Bad input, unbounded runs, meaningless results, untrusted files and the periodicity flag:
every check is raised before any computation, against independent references."""

import json
import subprocess
import sys
import textwrap
import warnings
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from mbs_clearance import AccuracyWarning, SliderCrank, simulate
from mbs_clearance._checks import MemoryLimitError
from mbs_clearance._warnings import PhysicsWarning
from mbs_clearance.analysis.sensitivity import load_sensitivities, sensitivities
from mbs_clearance.model.mechanism import RPM
from mbs_clearance.solve import linkage_model, reduced
from mbs_clearance.solve.simulate import peak_base_force
from mbs_clearance.solve.trajectory import PENETRATION_LIMIT, load_trajectory


@pytest.fixture
def no_integration(monkeypatch):
    """Any call of the reduced model's integrator fails the test: the checks must come
    first."""
    def forbidden(*args, **kwargs):
        raise AssertionError("the integrator ran before the input was checked")

    monkeypatch.setattr(linkage_model, "integrate", forbidden)


NAN = float("nan")
BAD_REDUCED = [
    (dict(t_eval=[]), "t_eval must be a non-empty array"),
    (dict(t_eval=[0.0, NAN]), "t_eval must be a non-empty array of finite"),
    (dict(t_eval=[0.002, 0.001]), "strictly increasing"),
    (dict(event_tol=0.0), r"event_tol \(penetration tolerance of events\) must be a finite "
                          r"number > 0"),
    (dict(event_tol=NAN), "event_tol"),
    (dict(h0=NAN), r"h0 \(initial step; 0: automatic\) must be a finite number >= 0"),
    (dict(h0=-1e-6), "h0"),
    (dict(h_max=0.0), r"h_max \(largest step\) must be a finite number > 0"),
    (dict(h_max=-1.0), "h_max"),
    (dict(n_samples=-1), r"n_samples \(interior event samples per step\) must be an integer "
                         r"in \[0, 1000\]"),
    (dict(max_steps=0), "max_steps must be an integer >= 1"),
    (dict(max_steps=2.5), "max_steps must be an integer"),
    (dict(atol=0.0), "atol must be a finite number > 0"),
    (dict(atol=NAN), "atol"),
    (dict(atol=[1e-9, 1e-9]), "atol must be a finite number > 0 or 5 of them"),
    (dict(rtol=NAN), r"rtol must be a finite number in \[1e-14, 0.01\]"),
    (dict(rtol=True), "rtol"),
    (dict(initial_offset=2.0), r"initial_offset \(fraction of the clearance\) must be a "
                               r"finite number in \[-1, 1\]"),
    (dict(max_memory=0), r"max_memory \(bytes\) must be an integer >= 1"),
    (dict(method=3), "method must be one of"),
]


@pytest.mark.parametrize("options,message", BAD_REDUCED)
def test_reduced_options_checked_before_integration(paper, no_integration, options, message):
    with pytest.raises(ValueError, match=message):
        simulate(paper, 2, **options)
    with pytest.raises(ValueError, match=message):
        peak_base_force(paper, 2, **options)


def test_numpy_scalars_accepted_and_booleans_refused(paper):
    ref = simulate(paper, 1, rtol=1e-6)
    for rtol, revs in ((np.float64(1e-6), np.int64(1)), (1e-6, np.int32(1))):
        traj = simulate(paper, revs, rtol=rtol)
        np.testing.assert_array_equal(traj.peaks, ref.peaks)
    assert simulate(paper, 1, rtol=np.float32(1e-6)).stats["naccept"] > 0
    assert ref.max_base_force(np.int64(1)) == ref.max_base_force(1)
    with pytest.raises(ValueError, match="revolution must be an integer >= 1; got True"):
        ref.max_base_force(True)
    with pytest.raises(ValueError, match="revolutions must be an integer >= 1; got True"):
        simulate(paper, True)
    with pytest.raises(ValueError, match="revolution must be an integer >= 1; got True"):
        peak_base_force(paper, True)


def test_sensitivities_options(paper, monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("integrated before checking")

    monkeypatch.setattr(reduced, "run", forbidden)
    for kwargs, message in ((dict(revolutions=True), "revolutions must be an integer"),
                            (dict(revolutions=0), "revolutions must be an integer >= 1"),
                            (dict(rtol=NAN), "rtol must be a finite number"),
                            (dict(t_eval=[]), "t_eval must be a non-empty"),
                            (dict(fd_relative_step=0.5), "fd_relative_step must be a finite"),
                            (dict(event_time_term=1), "event_time_term must be True or False"),
                            (dict(method="adjoint"), "method must be one of")):
        with pytest.raises(ValueError, match=message):
            sensitivities(paper, ["slider_mass"], **kwargs)


def test_exudyn_and_ideal_options(paper):
    from mbs_clearance.backends.exudyn_model import make_settings

    for options, message in ((dict(step_size=NAN), "step_size must be a finite number > 0"),
                             (dict(step_size=-1e-6), "step_size"),
                             (dict(spectral_radius=2.0), r"spectral_radius .* in \[0, 1\]"),
                             (dict(modified_newton=1), "modified_newton must be True or"),
                             (dict(contact="spring"), "contact must be one of"),
                             (dict(newton_tolerance=0.0), "newton_tolerance must be a finite"),
                             (dict(onset="late"), "onset must be one of")):
        with pytest.raises(ValueError, match=message):
            make_settings(options)
    assert make_settings(dict(step_size=np.float32(1e-6))).step_size == float(np.float32(1e-6))
    with pytest.raises(ValueError, match="samples_per_revolution must be an integer >= 8"):
        simulate(paper, 1, backend="ideal", samples_per_revolution=4)
    a = simulate(paper, 1, backend="ideal", samples_per_revolution=np.int64(16))
    assert len(a.t) == 17


def test_numeric_fields_stored_as_float_and_saved(tmp_path):
    mech = SliderCrank(crank_length=np.float32(0.05), slider_mass=Fraction(7, 50),
                       crank_mass=np.int64(1), coupler_inertia=np.float64(4e-4))
    for name in ("crank_length", "slider_mass", "crank_mass", "coupler_inertia"):
        assert type(getattr(mech, name)) is float, name
    assert mech.slider_mass == 0.14 and mech.crank_mass == 1.0
    traj = simulate(mech, 1, backend="ideal", samples_per_revolution=16)
    for suffix in (".npz", ".csv"):
        back = load_trajectory(traj.save(tmp_path / f"t{suffix}"))
        assert back.mechanism == mech
    with pytest.raises(ValueError, match="crank_length must be a finite number"):
        SliderCrank(crank_length=10**400)
    with pytest.raises(ValueError, match="crank_length must be a finite number > 0"):
        SliderCrank(crank_length=np.float32("nan"))


# ------------------------------------------------------------------------ unbounded runs
def test_huge_runs_refused_before_allocating(paper, no_integration):
    # 1e9 revolutions: 24 GB for the per-revolution arrays alone (24 bytes each)
    with pytest.raises(MemoryLimitError, match="per-revolution arrays alone.*max_memory"):
        simulate(paper, 10**9)
    with pytest.raises(MemoryLimitError, match="per-revolution arrays alone"):
        peak_base_force(paper, 10**9)
    # h_max alone forces more steps than max_steps
    with pytest.raises(MemoryLimitError, match="takes at least 8e\\+05 steps, more than "
                                               "max_steps=1000"):
        simulate(paper, 10**5, max_steps=1000)
    # Exudyn at 1 rpm: 1.6e7 fixed steps (the contact's period sets the step) of every
    # sensor, about 15 GiB
    with pytest.raises(MemoryLimitError, match="1.6e\\+07 fixed steps .* GiB.*max_memory"):
        simulate(SliderCrank(crank_speed=RPM), 4, backend="exudyn")
    with pytest.raises(MemoryLimitError, match="max_memory"):
        simulate(paper, 10**4, backend="ideal")


def test_pilot_refuses_a_run_that_would_hit_max_steps(paper):
    # the pilot revolution (about 1700 steps, an independent count: a plain simulation's)
    # predicts 100 revolutions at about 1.7e5 steps
    one = simulate(paper, 1).stats
    per_rev = one["naccept"] + one["nreject"]
    with pytest.raises(MemoryLimitError, match="needs about .* steps .* max_steps=100000"):
        peak_base_force(paper, 100, max_steps=100_000)
    assert 100 * per_rev > 100_000


def test_record_never_outgrows_max_memory(paper):
    traj = simulate(paper, 1)
    steps = len(traj.t)
    per_step = linkage_model.bytes_per_step(reduced.MODEL)
    limit = steps * per_step // 2
    with pytest.raises(MemoryLimitError, match="record reached max_memory"):
        simulate(paper, 1, max_memory=limit)
    again = simulate(paper, 1, max_memory=2 * steps * per_step + 10**4)
    np.testing.assert_array_equal(again.t, traj.t)


MEMORY_PROBE = textwrap.dedent("""
    import json
    from mbs_clearance import SliderCrank
    from mbs_clearance.solve import linkage_model, reduced
    from mbs_clearance.solve.simulate import peak_base_force, simulate

    def peak_rss():
        # the resident-set high-water mark since the last reset (Linux)
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024

    def reset():
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")

    m = SliderCrank()
    # the peak-only run: one run at a fixed rtol (the default is error-controlled and records)
    simulate(m, 1); peak_base_force(m, 1, rtol=1e-7)          # load the kernels
    reset(); r0 = peak_rss()
    peak_base_force(m, 40, rtol=1e-7)
    r1 = peak_rss()
    reset(); r2 = peak_rss()
    traj = simulate(m, 40)
    r3 = peak_rss()
    steps = traj.stats["naccept"] + traj.stats["nreject"]
    print(json.dumps({"peak": r1 - r0, "record": r3 - r2, "steps": steps,
                      "per_step": linkage_model.bytes_per_step(reduced.MODEL)}))
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self (Linux)")
def test_memory_estimate_bounds_a_real_run_and_peak_runs_need_no_record():
    """In a fresh process (the resident-set high-water mark, reset before each run): a
    40-revolution recording run's memory growth stays below the estimate (steps x
    bytes_per_step) and above a quarter of it; a peak-only run of the same length adds no
    record (growth below 2 MB, while the record of the same steps is tens of MB)."""
    out = subprocess.run([sys.executable, "-c", MEMORY_PROBE], capture_output=True, text=True,
                         check=True, cwd=str(Path(__file__).parents[2]))
    r = json.loads(out.stdout.strip().splitlines()[-1])
    estimate = r["steps"] * r["per_step"]
    assert r["record"] <= estimate <= 4 * r["record"], r
    assert r["peak"] < 2 * 1024**2, r
    assert r["record"] > 10 * 1024**2, r


def test_peak_only_run_records_nothing(paper):
    ts, ys, ms, peaks, _, counters, outs, _ = reduced.run(paper, 20, record=False)
    assert ts.shape == (0,) and ys.shape[0] == 0 and outs.shape[0] == 0
    assert len(peaks) == 20 and counters[1] > 20 * 1000


# --------------------------------------------------------------- meaningless penetration
def test_huge_speed_flagged_normal_cases_not(paper):
    with pytest.warns(PhysicsWarning, match="journal radii"):
        traj = simulate(paper.replace(crank_speed=1e6), 1)
    pen = traj.penetration.max()
    assert traj.stats["penetration_meaningless"] is True
    assert traj.stats["max_penetration_radius"] == pytest.approx(pen / paper.journal_radius)
    assert pen > paper.journal_radius          # the journal sinks deeper than its radius
    normal = simulate(paper, 1)
    assert normal.stats["penetration_meaningless"] is False
    assert normal.stats["max_penetration_clearance"] == pytest.approx(
        normal.penetration.max() / paper.clearance)
    assert normal.stats["max_penetration_radius"] < PENETRATION_LIMIT / 10


# --------------------------------------------------------------------- untrusted files
@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    traj = simulate(SliderCrank(), 2)
    path = traj.save(tmp_path_factory.mktemp("traj") / "t.npz")
    return traj, path


def _rewrite(src, dst, change):
    with np.load(src) as d:
        arrays = {k: d[k] for k in d.files}
    meta = json.loads(str(arrays["meta"]))
    change(arrays, meta)
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(dst, **arrays)
    return dst


@pytest.mark.parametrize("change,message", [
    (lambda a, m: m.__setitem__("peaks", [2 * p for p in m["peaks"]]),
     "stored peak of revolution 1"),
    (lambda a, m: m.__setitem__("peaks", [0.5 * p for p in m["peaks"]]),
     "stored peak of revolution 1"),
    (lambda a, m: m.__setitem__("peaks", m["peaks"][:1]), "1 peaks for 2 revolutions"),
    (lambda a, m: a.__setitem__("penetration", a["penetration"][:-1]),
     "'penetration' has .* samples, 't' has"),
    (lambda a, m: a.__setitem__("base_force", a["base_force"][:, :1]),
     "'base_force' has shape"),
    (lambda a, m: a["crank_moment"].__setitem__(3, np.nan), "'crank_moment' holds non-finite"),
    (lambda a, m: a.__setitem__("t", a["t"][::-1].copy()), "not strictly increasing"),
    (lambda a, m: m.__setitem__("mechanism", [1, 2]), "'mechanism' object"),
    (lambda a, m: m.pop("backend"), "'backend' must be a string"),
    (lambda a, m: m["mechanism"].__setitem__("crank_length", -1), "bad mechanism"),
])
def test_loader_checks_consistency(saved, tmp_path, change, message):
    traj, path = saved
    bad = _rewrite(path, tmp_path / "bad.npz", change)
    with pytest.raises(ValueError, match=f"inconsistent trajectory file .*bad.npz.*{message}"):
        load_trajectory(bad)
    # the untouched file loads, and its peaks are the simulation's
    assert load_trajectory(path).max_base_force(2) == traj.max_base_force(2)


def test_sensitivities_loader_checks(paper, tmp_path):
    sens = sensitivities(paper, ["slider_mass"], 1, rtol=1e-6)
    path = sens.save(tmp_path / "s.npz")
    assert load_sensitivities(path).parameters == ("slider_mass",)
    with np.load(path) as d:
        arrays = {k: d[k] for k in d.files}
    for key, value, message in (
            ("crank_moment", arrays["crank_moment"][:-1], "'crank_moment' has shape"),
            ("parameters", np.array(["nope"]), "unknown parameter name"),
            ("base_force", np.full_like(arrays["base_force"], np.inf), "non-finite"),
            ("method", np.array("magic"), "method must be 'ddm' or 'fd'"),
            ("t", arrays["t"] + 1e-3, "time grid")):
        changed = dict(arrays, **{key: value})
        np.savez(path, **changed)
        with pytest.raises(ValueError, match=f"inconsistent sensitivities file .*{message}"):
            load_sensitivities(path)


# ------------------------------------------------------------------------- periodicity
def test_periodicity_flag_in_simulate(paper):
    """Independent reference: the DDM growth diagnostic (docs/sensitivity.md) calls the
    paper case periodic, c = 0.1 mm and 0.5 mm chaotic; 100 rpm drifts along the wall."""
    assert simulate(paper, 4).stats["periodic"] is True
    for mech in (paper.replace(journal_radius=0.0099), paper.replace(journal_radius=0.0095),
                 paper.replace(crank_speed=100 * RPM)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            traj = simulate(mech, 4)
        assert traj.stats["periodic"] is False, traj.stats["periodicity_note"]
        assert "not periodic" in traj.stats["periodicity_note"]
        # a run flagged inaccurate (the two large clearances rattle) warns, the others not
        warned = [w for w in caught if issubclass(w.category, AccuracyWarning)]
        assert bool(warned) == (traj.stats["accuracy_ok"] is False), traj.stats
    short = simulate(paper, 2).stats
    assert short["periodic"] is None and "at least 3 revolutions" in short["periodicity_note"]
    loose = simulate(paper, 4, rtol=1e-4).stats
    assert loose["periodic"] is None and "use a smaller rtol" in loose["periodicity_note"]
    ideal = simulate(paper, 3, backend="ideal").stats
    assert ideal["periodic"] is True


def test_sensitivity_periodicity_undetermined_and_slow_growth(paper):
    short = sensitivities(paper, ["slider_mass"], 2, rtol=1e-8)
    assert short.periodic is None and not short.chaotic
    assert "needs at least 3" in short.periodicity_note
    slow = sensitivities(paper.replace(crank_speed=100 * RPM), ["slider_mass"], 4, rtol=1e-8)
    # the last-two-revolutions ratio misses it (below 2), the fitted trend does not
    assert np.all(slow.growth_rate < 2.0)
    assert slow.periodic is False and slow.chaotic
    g = slow.growth[1:, 0]
    assert np.all(np.diff(g) > 0.2 * g[0])      # steady growth, checked on the raw maxima


def test_periodicity_and_penetration_stats_with_exudyn(paper):
    """The independent Exudyn model gives the same verdicts as the reduced one: the paper
    case periodic, c = 0.1 mm not; and the same penetration ratio (first impact, 0.89 c)."""
    pytest.importorskip("exudyn")
    traj = simulate(paper, 4, backend="exudyn")
    ref = simulate(paper, 4)
    assert traj.stats["periodic"] is True
    assert traj.stats["max_penetration_clearance"] == pytest.approx(
        ref.stats["max_penetration_clearance"], rel=0.01)
    chaotic = simulate(paper.replace(journal_radius=0.0099), 4, backend="exudyn")
    assert chaotic.stats["periodic"] is False
