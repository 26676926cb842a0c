"""Work too large for the machine is refused before it starts, in one line naming the options,
the estimate and the limit; unreachable schedulers, damaged maps, foreign output folders,
inputs outside a field's range and flagged runs say so instead of failing late or silently."""

from __future__ import annotations

import socket
import threading
import time

import numpy as np
import pytest

from mbs_clearance import AccuracyWarning, SliderCrank, simulate
from mbs_clearance._checks import MemoryLimitError
from mbs_clearance.cli import main
from mbs_clearance.studies import sweep as sweep_mod

GRID_1E8 = ["clearance=1e-5:1e-3:log:10000", "crank_speed=100:1000:10000"]


def _refused_fast(fn, match):
    t0 = time.perf_counter()
    with pytest.raises(MemoryLimitError, match=match):
        fn()
    assert time.perf_counter() - t0 < 1.0


# ------------------------------------------------------------------------ sizes, library
def test_map_sizes_refused_before_any_design(monkeypatch):
    built = []
    real = sweep_mod.design_at

    def counting(*args, **kw):
        built.append(args)
        return real(*args, **kw)

    monkeypatch.setattr(sweep_mod, "design_at", counting)
    _refused_fast(lambda: sweep_mod.regime_map(SliderCrank(), GRID_1E8),
                  r"10000 x 10000 = 100000000 points with keep=50 needs about .* GiB, more "
                  r"than max_memory=\d+ bytes")
    _refused_fast(lambda: sweep_mod.regime_map(SliderCrank(), ["clearance=1e-5:1e-3:1000",
                                                               "crank_speed=100:1000:1000"]),
                  "1000000 points")
    _refused_fast(lambda: sweep_mod.regime_map(SliderCrank(), "clearance=1e-5:1e-3:3",
                                               revolutions=10**9),
                  r"revolutions=1000000000: each point's run needs")
    assert built == []
    # a grid that fits is not refused by the estimate (and the limit is the caller's)
    assert sweep_mod.map_memory((60, 40), 100, 50, 8, 1) < 64 * 1024**2
    with pytest.raises(MemoryLimitError, match="max_memory=1000000 bytes"):
        sweep_mod.map_memory((60, 40), 100, 50, 8, 1, max_memory=10**6)


def test_a_sweep_axis_too_long_is_refused_before_its_values():
    _refused_fast(lambda: sweep_mod.parse_sweep("clearance=1e-5:1e-3:1000000000"),
                  "sweep clearance with 1000000000 points")


def test_long_runs_refused_in_every_function():
    from mbs_clearance import lyapunov_exponent, poincare_section, sensitivities
    from mbs_clearance.model.cases import CASES

    paper = SliderCrank()
    _refused_fast(lambda: sensitivities(paper, ["crank_length"], 10**9),
                  "revolutions=1000000000: the per-revolution arrays alone need")
    _refused_fast(lambda: sensitivities(paper, ["crank_length"], 10**9, method="fd"),
                  "revolutions=1000000000")
    _refused_fast(lambda: sensitivities(CASES["four_bar"](), None, 10**9),
                  "revolutions=1000000000")
    _refused_fast(lambda: lyapunov_exponent(paper, 10**9), "revolutions=1000000000")
    _refused_fast(lambda: poincare_section(paper, 10**9), "revolutions=1000000000")


def test_ga_size_refused_before_any_simulation(monkeypatch):
    from mbs_clearance.studies import optimize

    def never(*args, **kw):
        raise AssertionError("a design was simulated")

    monkeypatch.setattr(optimize, "peak_base_force", never)
    _refused_fast(lambda: optimize.optimize_link_lengths(population=10**9, progress=False),
                  r"population=1000000000 x generations=30: the GA needs about .* TiB")
    _refused_fast(lambda: optimize.optimize_link_lengths(population=10**4, generations=10**5,
                                                         progress=False),
                  r"population=10000 x generations=100000")


def test_tolerance_sample_sizes_refused_before_sampling(monkeypatch):
    from mbs_clearance.studies import tolerance as tol

    def never(*args, **kw):
        raise AssertionError("a sample was evaluated")

    monkeypatch.setattr(tol, "evaluate", never)
    inputs = {"crank_length": tol.band(0.05, 1e-4)}
    _refused_fast(lambda: tol.tolerance_study(inputs, sobol=2**30, progress=False),
                  r"sobol=1073741824 \(4294967296 runs over 1 inputs\)")
    _refused_fast(lambda: tol.tolerance_study(inputs, sobol=0, monte_carlo=10**9,
                                              progress=False), "monte_carlo=1000000000")
    _refused_fast(lambda: tol.tolerance_study(inputs, sobol=0, morris=10**9,
                                              progress=False), "morris=1000000000")
    _refused_fast(lambda: tol.tolerance_study(inputs, sobol=0, dgsm=10**9, progress=False),
                  "dgsm=1000000000")


@pytest.mark.parametrize("argv, match", [
    (["map", *sum((["--sweep", s] for s in GRID_1E8), [])], "100000000 points"),
    (["map", "--sweep", "clearance=1e-5:1e-3:3", "--revolutions", "1000000000"],
     "--revolutions 1000000000"),
    (["sensitivity", "--revolutions", "1000000000"], "--revolutions 1000000000"),
    (["lyapunov", "--revolutions", "1000000000"], "--revolutions 1000000000"),
    (["optimize", "--population", "1000000000"], "population=1000000000"),
])
def test_cli_sizes_one_line_before_any_output(tmp_path, monkeypatch, capsys, argv, match):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.count("\n") == 1 and match in err, err
    # a memory estimate, or the step estimate of the runs (at least 8 steps a revolution)
    assert ("max_memory" in err or "max_steps" in err) and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []            # no folder made


def test_cli_tolerance_sizes(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "in.json").write_text('{"crank_length": {"band": [0.05, 1e-4]}}')
    with pytest.raises(SystemExit) as exc:
        main(["tolerance", "in.json", "--sobol", "1073741824"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.count("\n") == 1 and "sobol=1073741824" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.json"]


# ------------------------------------------------------------------------ dask scheduler
class _Server:
    """A TCP server on localhost that accepts and then sends `reply` (None: stays silent)."""

    def __init__(self, reply: bytes | None):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.address = f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"
        self.reply, self.conns = reply, []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            if self.reply is not None:
                try:
                    conn.recv(64)
                    conn.sendall(self.reply)
                except OSError:
                    pass

    def close(self):
        for c in self.conns:
            c.close()
        self.sock.close()


@pytest.mark.parametrize("reply, error, match", [
    (None, TimeoutError, r"within 2 s"),
    (b"HTTP/1.1 400 Bad Request\r\nconnection: close\r\ncontent-length: 0\r\n\r\n",
     ConnectionError, "does not speak dask's protocol"),
])
def test_a_server_that_is_not_a_scheduler_is_refused_in_bounded_time(reply, error, match):
    pytest.importorskip("distributed")
    from mbs_clearance.studies.executor import connect_dask

    server = _Server(reply)
    try:
        t0 = time.perf_counter()
        with pytest.raises(error, match=match) as exc:
            connect_dask(server.address, timeout=2.0)
        assert time.perf_counter() - t0 < 10.0
        assert str(exc.value).startswith(
            f"could not connect to the dask scheduler at {server.address!r}")
        assert "allocate" not in str(exc.value)
    finally:
        server.close()


def test_cli_map_with_a_foreign_server_leaves_nothing(tmp_path, monkeypatch, capsys):
    pytest.importorskip("distributed")
    server = _Server(b"HTTP/1.1 400 Bad Request\r\n\r\n")
    monkeypatch.chdir(tmp_path)
    try:
        with pytest.raises(SystemExit) as exc:
            main(["map", "--sweep", "clearance=1e-5:1e-3:3", "--scheduler", server.address,
                  "--no-progress"])
    finally:
        server.close()
    err = capsys.readouterr().err
    assert exc.value.code == 1 and err.count("\n") == 1
    assert "could not connect to the dask scheduler" in err and "memory" not in err
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------ map output folder
def test_map_out_follows_the_output_folder_rule(tmp_path, monkeypatch, capsys):
    def never(*args, **kw):
        raise AssertionError("the map was computed")

    monkeypatch.setattr(sweep_mod, "regime_map", never)
    out = tmp_path / "map"
    out.mkdir()
    (out / "bifurcation.png").write_bytes(b"the user's own figure")
    with pytest.raises(SystemExit) as exc:
        main(["map", "--sweep", "clearance=1e-5:1e-3:3", "--out", str(out)])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "did not write" in err and "--force" in err
    assert (out / "bifurcation.png").read_bytes() == b"the user's own figure"
    # a map.nc that is no map of ours is foreign too
    (out / "bifurcation.png").unlink()
    (out / "map.nc").write_bytes(b"CDF\x01 not really")
    with pytest.raises(SystemExit):
        main(["map", "--sweep", "clearance=1e-5:1e-3:3", "--out", str(out)])
    err = capsys.readouterr().err
    assert "did not write" in err and "'map.nc'" in err      # the file named


def test_a_second_run_into_the_same_folder_is_refused(tmp_path):
    from mbs_clearance._io import folder_lock

    with folder_lock(tmp_path / "map", "--out"):
        with pytest.raises(ValueError, match="'.*map' is in use by another mbs-clearance run"):
            with folder_lock(tmp_path / "map", "--out"):
                pass
    with folder_lock(tmp_path / "map", "--out"):    # free again once the first has ended
        pass


@pytest.mark.parametrize("content", [b"garbage\n", b"CDF\x01\x00\x00\x00\x00"])
def test_a_damaged_map_is_named(tmp_path, content):
    bad = tmp_path / "map.nc"
    bad.write_bytes(content)
    with pytest.raises(ValueError, match=f"cannot read the regime map {str(bad)!r}"):
        sweep_mod.load_map(bad)


def test_a_netcdf_file_that_is_not_a_map_is_named(tmp_path):
    import xarray as xr

    other = tmp_path / "other.nc"
    xr.Dataset({"a": ("x", [1.0, 2.0])}).to_netcdf(other, engine="scipy")
    with pytest.raises(ValueError, match="not a regime map of mbs-clearance"):
        sweep_mod.load_map(other)


def test_a_full_disk_while_the_map_is_written_keeps_the_last_file(tmp_path, monkeypatch):
    import xarray as xr

    path = tmp_path / "map.nc"
    small = dict(revolutions=6, keep=5, max_period=2, scheduler="serial")
    sweep_mod.regime_map(SliderCrank(), "clearance=1e-5,2e-5", out=path, **small)
    before = path.read_bytes()

    def full(self, target, *args, **kw):
        with open(target, "wb") as fh:
            fh.write(b"CDF\x01 half")
        raise OSError(28, "No space left on device", str(target))

    monkeypatch.setattr(xr.Dataset, "to_netcdf", full)
    with pytest.raises(OSError, match="No space left"):
        sweep_mod.regime_map(SliderCrank(), "clearance=1e-5,2e-5,3e-5", out=tmp_path / "b.nc",
                             **small)
    with pytest.raises(OSError, match="No space left"):
        sweep_mod._write(sweep_mod.load_map(path), path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.nc"]   # no partial file


# ------------------------------------------------------------------------ report inputs
@pytest.mark.parametrize("content, match", [
    (b"garbage\n", "cannot read the regime map"),
    (None, "no such file"),
])
def test_report_checks_map_before_any_section(tmp_path, monkeypatch, capsys, content, match):
    report = pytest.importorskip("validation.report")

    def never(*args, **kw):
        raise AssertionError("a section was computed")

    for name in report.SECTIONS:
        monkeypatch.setattr(report, f"section_{name}", never, raising=False)
    bad = tmp_path / "map.nc"
    if content is not None:
        bad.write_bytes(content)
    with pytest.raises(SystemExit) as exc:
        main(["report", "--map", str(bad), "--out", str(tmp_path / "report")])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.count("\n") == 1 and match in err
    assert str(bad) in err and "--map" in err
    with pytest.raises(SystemExit):
        main(["report", "--map", str(bad), "--replot", "--out", str(tmp_path / "r")])
    assert "--replot" in capsys.readouterr().err


# ------------------------------------------------------------------------ tolerance ranges
@pytest.mark.parametrize("inputs, kw, match", [
    ({"crank_length": ("uniform", -1.0, 0.05)}, {},
     r"input 'crank_length': uniform \[-1, 0.05\] reaches -1, outside"),
    ({"slider_mass": ("normal", 0.14, 0.05)}, {},
     r"input 'slider_mass': normal\(0.14, 0.05\) over mean \+- 5 sigma reaches -0.11"),
    ({"crank_length": ("uniform", 0.04, 0.06), "coupler_length": ("uniform", 0.055, 0.12)},
     {},
     r"together reach an invalid design"),
    ({"radial_clearance": ("fit",)}, {"monte_carlo": 4, "wear": [1.0]},
     r"wear 1 m leaves the design's valid range"),
])
def test_tolerance_inputs_outside_a_fields_range_refused_before_sampling(
        monkeypatch, inputs, kw, match):
    from mbs_clearance.studies import tolerance as tol

    def never(*args, **kw):
        raise AssertionError("a sample was evaluated")

    monkeypatch.setattr(tol, "evaluate", never)
    make = {"uniform": tol.Uniform, "normal": tol.Normal,
            "fit": lambda: tol.FitClearance("H7/g6", 0.02)}
    dists = {n: make[spec[0]](*spec[1:]) for n, spec in inputs.items()}
    with pytest.raises(ValueError, match=match):
        tol.tolerance_study(dists, progress=False, **{"sobol": 0, **kw} if kw else {})


def test_tolerance_cli_bad_range_is_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "in.json").write_text('{"crank_length": {"uniform": [-1, 0.05]}}')
    with pytest.raises(SystemExit) as exc:
        main(["tolerance", "in.json"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.count("\n") == 1 and "input 'crank_length'" in err
    assert "KeyError" not in err and "internal error" not in err


def test_summary_of_a_study_with_failed_runs():
    from mbs_clearance.studies.tolerance import ToleranceResult

    res = ToleranceResult(names=("a",), distributions={}, output="peak",
                          sobol={"N": 8, "runs": 24, "failed": 3},
                          morris={"runs": 6, "failed": 1}, counts={"runs": 30, "failed": 4})
    text = res.summary()
    assert "indices not computed: 3 runs failed" in text
    assert "indices not computed: 1 runs failed" in text


# ------------------------------------------------------------------------ flagged runs warn
@pytest.mark.parametrize("fields", [dict(youngs_modulus=1e15),
                                    dict(crank_mass=1e-6, coupler_mass=1e-6,
                                         slider_mass=1e-6)])
def test_every_run_flagged_inaccurate_warns(fields):
    with pytest.warns(AccuracyWarning, match="rattles") as caught:
        traj = simulate(SliderCrank(**fields), 4)
    assert traj.stats["accuracy_ok"] is False
    assert str(caught[0].message) == traj.stats["accuracy_note"]


def test_the_start_up_transient_is_not_rattling():
    # the paper's case switches contact 5 times, all in revolution 1 (the journal starts
    # centred): a one-revolution run is accurate and says nothing
    traj = simulate(SliderCrank(), 1)
    assert traj.stats["nevent"] == 5 and traj.stats["accuracy_ok"] is True


# ------------------------------------------------------------------------ defaults adapt
def test_lyapunov_default_transient_follows_revolutions():
    import inspect

    from mbs_clearance import lyapunov_exponent

    assert inspect.signature(lyapunov_exponent).parameters["transient"].default is None
    res = lyapunov_exponent(SliderCrank(), revolutions=6)
    assert res.transient == 3 and len(res.log_growth) == 6
    assert np.isfinite(res.per_revolution)
    with pytest.raises(ValueError, match=r"transient .* must be an integer in \[0, 5\]"):
        lyapunov_exponent(SliderCrank(), revolutions=6, transient=6)


def test_a_real_scheduler_passes_the_probe():
    distributed = pytest.importorskip("dask.distributed")
    from mbs_clearance.studies.executor import connect_dask

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as cluster:
        t0 = time.perf_counter()
        client = connect_dask(cluster.scheduler_address, timeout=10.0)
        try:
            assert time.perf_counter() - t0 < 10.0
            assert client.submit(sum, [1, 2, 3]).result(timeout=30) == 6
        finally:
            client.close()
