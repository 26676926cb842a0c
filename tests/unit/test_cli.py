"""The command line calls the public functions and reports bad input clearly."""

import json
import re

import numpy as np
import pytest

from mbs_clearance import AccuracyWarning, SliderCrank, load_trajectory, peak_base_force
from mbs_clearance.cli import main


def test_simulate_writes_trajectory_and_figure(tmp_path, capsys):
    out, fig = tmp_path / "t.npz", tmp_path / "f.png"
    with pytest.warns(AccuracyWarning, match="rattles"):    # c = 0.1 mm: not periodic
        assert main(["simulate", "--revolutions", "2", "--journal-radius", "0.0099",
                     "--out", str(out), "--plot", str(fig)]) == 0
    traj = load_trajectory(out)
    assert traj.mechanism == SliderCrank(journal_radius=0.0099)
    assert fig.stat().st_size > 10_000
    printed = capsys.readouterr().out.splitlines()
    peak2 = float(printed[2].split()[1])
    with pytest.warns(AccuracyWarning, match="rattles"):   # the same run to accuracy
        ref = peak_base_force(traj.mechanism, 2)
    assert peak2 == pytest.approx(ref, abs=0.01)
    np.testing.assert_allclose(traj.max_base_force(2), peak2, atol=0.01)


def test_simulate_with_another_integrator(capsys):
    assert main(["simulate", "--revolutions", "1", "--integrator", "dop853", "--rtol",
                 "1e-9"]) == 0
    peak1 = float(capsys.readouterr().out.splitlines()[1].split()[1])
    # the same peak as the default integrator, to the accuracy of both at rtol 1e-9
    assert peak1 == pytest.approx(peak_base_force(SliderCrank(), 1, rtol=1e-9), rel=1e-6)


def test_config_file_and_override(tmp_path, capsys):
    cfg = tmp_path / "m.json"
    cfg.write_text(json.dumps({"restitution": 0.5, "crank_length": 0.04}))
    assert main(["simulate", "--revolutions", "1", "--config", str(cfg),
                 "--crank-length", "0.045", "--out", str(tmp_path / "t.csv")]) == 0
    m = load_trajectory(tmp_path / "t.csv").mechanism
    assert (m.restitution, m.crank_length) == (0.5, 0.045)


@pytest.mark.parametrize("argv,message", [
    (["simulate", "--restitution", "0"], "restitution must be in the interval (0, 1]"),
    (["simulate", "--journal-radius", "0.02"], "journal_radius must be smaller"),
    (["simulate", "--config", "/nonexistent.json"], "cannot read mechanism file"),
    (["simulate", "--out", "x.txt", "--revolutions", "1"], "--out must end in .npz or .csv"),
    (["sensitivity", "--method", "fd", "--backend", "exudyn", "--integrator", "dop853"],
     "integrator applies to the reduced backend only"),
])
def test_bad_input_exits_with_message(argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert message in capsys.readouterr().err


# ------------------------------------------------------------------ options and parsing
def _table():
    """tools/bad_input_table.py as a module (tools/ is not a package)."""
    import importlib.util
    import sys
    from pathlib import Path

    if "bad_input_table" not in sys.modules:
        path = Path(__file__).resolve().parents[2] / "tools" / "bad_input_table.py"
        spec = importlib.util.spec_from_file_location("bad_input_table", path)
        module = importlib.util.module_from_spec(spec)
        sys.modules["bad_input_table"] = module
        spec.loader.exec_module(module)
    return sys.modules["bad_input_table"]


def _parse(argv):
    from mbs_clearance.cli import build_parser, mechanism_from_args

    return mechanism_from_args(build_parser().parse_args(argv))


def test_none_sets_the_derived_value_over_the_config_file(tmp_path):
    cfg = tmp_path / "m.json"
    cfg.write_text(json.dumps({"crank_inertia": 2e-4, "coupler_inertia": 1e-3,
                               "contact_stiffness": 1e9}))
    from_file = _parse(["simulate", "--config", str(cfg)])
    assert (from_file.crank_inertia, from_file.coupler_inertia,
            from_file.contact_stiffness) == (2e-4, 1e-3, 1e9)
    m = _parse(["simulate", "--config", str(cfg), "--crank-inertia", "none",
                "--coupler-inertia", "None", "--contact-stiffness", " NONE "])
    assert (m.crank_inertia, m.coupler_inertia, m.contact_stiffness) == (None, None, None)
    # the derived values: uniform thin rods m L^2 / 12 and the paper's Eq. 9 stiffness
    assert m.crank_inertia_value == pytest.approx(m.crank_mass * m.crank_length ** 2 / 12)
    assert m.coupler_inertia_value == pytest.approx(m.coupler_mass * m.coupler_length ** 2 / 12)
    assert m.stiffness == SliderCrank().stiffness != 1e9


def test_parameter_list_accepts_spaces_and_runs(capsys):
    from mbs_clearance.analysis.sensitivity import summary_sensitivities

    assert main(["sensitivity", "--parameters", "crank_length, slider_mass ",
                 "--revolutions", "1"]) == 0
    out = capsys.readouterr().out.splitlines()
    # the table's title names the output whose sensitivities it holds
    assert out[0].startswith("sensitivities of pivot_force:crank_pivot ")
    rows = out[2:4]
    # the summary's one definition (rtol 1e-9 on the uniform summary grid)
    ref = summary_sensitivities(SliderCrank(), ("crank_length", "slider_mass"), 1)
    assert [r.split()[0] for r in rows] == ["crank_length", "slider_mass"]
    assert rows[0].split()[1:3] == ["50", "mm"] and rows[1].split()[1:3] == ["0.14", "kg"]
    for row, r in zip(rows, ref.summary()):
        assert float(row.split()[-3]) == pytest.approx(r["mean_abs_normalized"], rel=1e-3)
    # every column is defined under the table
    for head in ("b0", "mean |S|", "max |S|", "growth/rev"):
        assert any(line.startswith(f"  {head}: ") for line in out[4:]), head


@pytest.mark.parametrize("argv,message", [
    (["sensitivity", "--parameters", ""], "needs at least one SliderCrank field"),
    (["sensitivity", "--parameters", "a,,b"], "has an empty name"),
    (["bench", "--repeats", "0"], "--repeats: must be an integer >= 1; got 0"),
    (["stress", "--backend", "nope"], "invalid choice: 'nope' (choose from 'reduced', "
                                      "'exudyn')"),
    (["simulate", "--rtol", "-1e-8"], "--rtol: must be a finite number > 0; got '-1e-8'"),
    (["simulate", "--revolutions", "0"], "--revolutions: must be an integer >= 1"),
    (["simulate", "--duration", "0.1"], "--duration and --window are for a free linkage"),
    (["optimize", "--population", "3"], "--population: must be an integer >= 4"),
    (["optimize", "--crank-bounds", "nan", "0.06"], "--crank-bounds: must be a finite"),
    (["compare", "--h-max", "-1"], "--h-max: must be a finite number > 0"),
    (["compare", "--step-size", "0"], "--step-size: must be a finite number > 0"),
])
def test_bad_option_values_are_one_line_usage_errors(argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"mbs-clearance {argv[0]}: error: ")
    assert message in err


def test_work_precision_rejects_zero_repeats():
    from validation.work_precision import run

    with pytest.raises(ValueError, match="repeats must be an integer >= 1; got 0"):
        run(quick=True, repeats=0)


# ------------------------------------------------------------------ errors: one line, codes
def _fail_with(monkeypatch, exc):
    import importlib

    sim = importlib.import_module("mbs_clearance.solve.simulate")   # the module, not the function

    def boom(*args, **kwargs):
        raise exc

    monkeypatch.setattr(sim, "simulate", boom)


@pytest.mark.parametrize("exc,code,shown", [
    (RuntimeError("integration failed: step size underflow"), 1,
     "integration failed: step size underflow"),
    (OSError(28, "No space left on device"), 1, "No space left on device"),
    (ValueError("h_max must be > 0\nsecond line"), 2, "h_max must be > 0; second line"),
    (KeyboardInterrupt(), 130, "interrupted"),
    (TypeError("unsupported operand"), 1, "internal error TypeError: unsupported operand"),
])
def test_failures_are_one_line_with_status(exc, code, shown, monkeypatch, capsys):
    monkeypatch.delenv("MBS_CLEARANCE_DEBUG", raising=False)
    _fail_with(monkeypatch, exc)
    with pytest.raises(SystemExit) as info:
        main(["simulate", "--revolutions", "1"])
    assert info.value.code == code
    err = capsys.readouterr().err
    assert err == f"mbs-clearance simulate: error: {shown}" + (
        " (a bug; rerun with MBS_CLEARANCE_DEBUG=1 for the traceback and report it)\n"
        if isinstance(exc, TypeError) else "\n")


def test_debug_variable_shows_the_traceback(monkeypatch, capsys):
    monkeypatch.setenv("MBS_CLEARANCE_DEBUG", "1")
    _fail_with(monkeypatch, TypeError("unsupported operand"))
    with pytest.raises(SystemExit):
        main(["simulate", "--revolutions", "1"])
    err = capsys.readouterr().err
    assert err.startswith("Traceback (most recent call last):")
    assert "TypeError: unsupported operand" in err
    assert err.splitlines()[-1].startswith("mbs-clearance simulate: error: internal error")


def test_console_script_in_a_real_process_prints_one_line(tmp_path):
    """The same through the interpreter (sys.exit(main())): a run refused before it starts
    (the step count --h-max forces is estimated first, naming the options) is one line with
    status 2."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "mbs_clearance.cli", "compare",
                           "--backend-b", "ideal", "--h-max", "1e-300", "--revolutions", "1",
                           "--no-plot"], capture_output=True, text=True, cwd=tmp_path,
                          env=_env())
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1, proc.stderr
    assert proc.stderr.startswith("mbs-clearance compare: error: --revolutions 1 with --h-max "
                                  "1e-300 s: a run of 1 revolutions"), proc.stderr
    assert "takes at least" in proc.stderr


def _env():
    import os
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    return {**os.environ, "PYTHONPATH": str(root), "MBS_CLEARANCE_DEBUG": ""}


# ------------------------------------------------------------------ outputs
def _plugin_modules(name):
    """validation.NAME as the tests import it and mbs_clearance_validation.NAME as the CLI's
    plugin entry points load it: two module objects of one file, both to be patched."""
    import importlib

    return [importlib.import_module(f"{package}.{name}")
            for package in ("validation", "mbs_clearance_validation")]


def _forbid_computing(monkeypatch):
    """Every entry point that computes raises: output checks must come first."""
    import mbs_clearance.analysis.sensitivity as sens_mod
    import validation.compare as cmp
    import validation.report as rep
    import validation.stress as stress
    import validation.work_precision as wp

    def forbidden(*args, **kwargs):
        raise AssertionError("computation started before the output path was checked")

    import importlib

    for module, name in ((importlib.import_module("mbs_clearance.studies.optimize"),
                          "optimize_link_lengths"),
                         (sens_mod, "sensitivities"), (wp, "run"), (stress, "run_sweep"),
                         (rep, "section_mechanism"), (rep, "section_response")):
        monkeypatch.setattr(module, name, forbidden)
    for plugin, name in (("work_precision", "run"), ("stress", "run_sweep"),
                         ("report", "section_mechanism"), ("report", "section_response")):
        for module in _plugin_modules(plugin):
            monkeypatch.setattr(module, name, forbidden)
    import sys

    monkeypatch.setattr(sys.modules["mbs_clearance.solve.simulate"], "simulate", forbidden)
    assert cmp  # compare imports simulate from mbs_clearance.solve.simulate at call time


def _output_cases():
    marks = ("--out", "--plot", "--json")
    return [c for c, _ in _table().CLI_CASES if any(m in c for m in marks)
            and "--replot" not in c]


@pytest.fixture
def user_folder(tmp_path, monkeypatch):
    _table()._make_user_files(tmp_path)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_output_paths_are_checked_before_computing(user_folder, monkeypatch, capsys):
    import shlex

    _forbid_computing(monkeypatch)
    cases = _output_cases()
    assert len(cases) >= 25
    before = sorted(p.relative_to(user_folder) for p in user_folder.rglob("*"))
    for command in cases:
        with pytest.raises(SystemExit) as exc:
            main(shlex.split(command))
        err = capsys.readouterr().err
        assert exc.value.code == 2, (command, err)
        assert err.count("\n") == 1 and "error: --" in err, (command, err)
        assert "AssertionError" not in err
    # nothing created, nothing changed (no partial folders or files left)
    assert sorted(p.relative_to(user_folder) for p in user_folder.rglob("*")) == before
    assert (user_folder / "user.txt").read_text() == "my notes\n"


@pytest.mark.skipif(__import__("os").geteuid() == 0,
                    reason="root writes into read-only folders; /proc covers it for root")
def test_read_only_folder_is_refused(tmp_path, monkeypatch, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    _forbid_computing(monkeypatch)
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--out", str(ro / "t.npz")])
    assert exc.value.code == 2
    assert "is not writable" in capsys.readouterr().err


def test_read_only_mount_is_refused(tmpfs, monkeypatch, capsys):
    """A real read-only file system (refused even for root, unlike chmod)."""
    ro = tmpfs("ro,size=64k")
    _forbid_computing(monkeypatch)
    for argv in (["simulate", "--out", str(ro / "t.npz")],
                 ["sensitivity", "--out", str(ro / "sens")],
                 ["report", "--out", str(ro / "report")]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        err = capsys.readouterr().err
        assert exc.value.code == 2
        assert err.endswith("is not writable (creating a file there fails: Read-only file "
                            "system)\n"), err


def test_own_files_are_replaced_user_files_need_force(tmp_path, capsys):
    out, fig = tmp_path / "t.npz", tmp_path / "t.png"
    argv = ["simulate", "--revolutions", "1", "--out", str(out), "--plot", str(fig)]
    assert main(argv) == 0
    assert main(argv + ["--restitution", "0.5"]) == 0     # ours: replaced without asking
    assert load_trajectory(out).mechanism.restitution == 0.5
    user = tmp_path / "mine.npz"
    user.write_bytes(b"my data")
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--revolutions", "1", "--out", str(user)])
    assert exc.value.code == 2 and "pass --force" in capsys.readouterr().err
    assert user.read_bytes() == b"my data"
    assert main(["simulate", "--revolutions", "1", "--out", str(user), "--force"]) == 0
    assert load_trajectory(user).mechanism == SliderCrank()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.npz", "t.npz", "t.png"]


def test_failed_write_leaves_the_old_file(tmp_path, monkeypatch, capsys):
    from mbs_clearance.solve.trajectory import Trajectory

    out = tmp_path / "t.npz"
    assert main(["simulate", "--revolutions", "1", "--out", str(out)]) == 0
    old = out.read_bytes()

    def disk_full(self, path):
        Path(path).write_bytes(b"half")
        raise OSError(28, "No space left on device")

    from pathlib import Path

    monkeypatch.setattr(Trajectory, "save", disk_full)
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--revolutions", "1", "--out", str(out), "--restitution", "0.5"])
    assert exc.value.code == 1
    # the run's note "done in ..." then the error, one line naming the file
    assert capsys.readouterr().err.splitlines()[-1] == ("mbs-clearance simulate: error: No "
                                                        f"space left on device: {str(out)!r}")
    assert out.read_bytes() == old
    assert [p.name for p in tmp_path.iterdir()] == ["t.npz"]


def test_output_folder_manifest_replace_and_force(tmp_path, capsys):
    from mbs_clearance._io import MANIFEST, verify_run_folder

    out = tmp_path / "sens"
    argv = ["sensitivity", "--parameters", "crank_length", "--revolutions", "1",
            "--out", str(out)]
    assert main(argv) == 0
    first = verify_run_folder(out)
    assert sorted(first["files"]) == sorted(p.name for p in out.iterdir()
                                            if p.name != MANIFEST)
    assert {"fig4_kinematic.png", "sensitivities.npz"} <= set(first["files"])
    assert main(argv) == 0                               # our folder: replaced
    second = verify_run_folder(out)
    assert second["run_id"] != first["run_id"]
    (out / "my_notes.txt").write_text("mine")            # a user's file inside: refused
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main(argv)
    assert "holds 'my_notes.txt'" in capsys.readouterr().err
    assert (out / "my_notes.txt").read_text() == "mine"
    assert json.loads((out / MANIFEST).read_text())["run_id"] == second["run_id"]
    assert main(argv + ["--force"]) == 0
    assert not (out / "my_notes.txt").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["sens"]   # no partial folder left


def test_killed_run_leaves_the_previous_folder(tmp_path):
    """SIGKILL a real `sensitivity --out` while it writes its folder: the folder still holds
    the previous complete run, and the next run cleans up the partial folder."""
    import signal
    import subprocess
    import sys
    import time

    from mbs_clearance._io import sha256, verify_run_folder

    out = tmp_path / "sens"
    argv = ["sensitivity", "--parameters", "crank_length", "--revolutions", "1",
            "--out", str(out)]
    assert main(argv) == 0
    before = verify_run_folder(out)
    digest = sha256(out / "sensitivities.npz")
    proc = subprocess.Popen([sys.executable, "-m", "mbs_clearance.cli", *argv,
                             "--restitution", "0.5"], env=_env(), cwd=tmp_path,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    partial = None
    deadline = time.monotonic() + 300
    while proc.poll() is None and time.monotonic() < deadline:
        found = list(tmp_path.glob(".sens.partial-*/sensitivities.npz"))
        if found:
            partial = found[0].parent
            break
        time.sleep(0.002)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert partial is not None, "the run ended before it could be killed while writing"
    assert proc.returncode == -signal.SIGKILL
    assert verify_run_folder(out) == before
    assert sha256(out / "sensitivities.npz") == digest
    assert partial.exists()                      # the killed run's leftovers ...
    assert main(argv) == 0
    assert not partial.exists()                  # ... removed by the next run
    assert [p.name for p in tmp_path.iterdir()] == ["sens"]


# ------------------------------------------------------------------ the bad-input table
def test_every_cli_bad_input_case_is_one_line_and_the_doc_is_current():
    """tools/bad_input_table.py's command-line cases: none prints a traceback or an internal
    error, each exits non-zero with exactly one line; docs/bad_input.md holds this table
    (regenerate with `python tools/bad_input_table.py`)."""
    from pathlib import Path

    table = _table()
    rows = table.run_cli_cases()
    assert len(rows) == len(table.CLI_CASES) >= 70
    for r in rows:
        err = r["stderr"]
        assert isinstance(r["status"], int) and r["status"] in (1, 2), r
        assert "Traceback" not in err and "internal error" not in err, r
        assert err.count("\n") == 1 and err.endswith("\n"), r
        first = r["command"].split()[:1]
        prog = " ".join(["mbs-clearance", *first]) if first != ["nope"] else "mbs-clearance"
        assert err.startswith(f"{prog}: error: "), r
    doc = (Path(__file__).resolve().parents[2] / "docs" / "bad_input.md").read_text()
    # the residual left by 50 Newton steps on a loop that cannot close wanders with the
    # last digits of each step (0.71 to 0.79 m from one BLAS to another): it is compared as
    # a number > 1e-9 of the length scale, the rest of the text exactly
    residual = re.compile(r"\(residual (\S+) m after")
    now = table.cli_section(table.document(rows, []))
    assert residual.findall(now) and all(float(x) > 1e-8 for x in residual.findall(now))
    assert residual.sub("(residual R m after", table.cli_section(doc)) \
        == residual.sub("(residual R m after", now)
    # the library section lists every library case of the script
    library = doc[doc.index(table.LIBRARY_HEADING):]
    for expr, _ in table.LIBRARY_CASES:
        assert f"`{table._cell(expr)}`" in library, expr


@pytest.mark.slow
def test_the_library_bad_input_table_is_what_each_case_gives():
    """tools/bad_input_table.py's library cases run afresh: docs/bad_input.md's Python API
    table holds, row by row, the exception and its message (or the value returned) and the
    warnings of each, word for word; numbers to 1e-6 relative, as the digits of a run's
    result (a peak, a penetration) move with the compiler's and the CPU's rounding
    (regenerate with `python tools/bad_input_table.py`)."""
    from pathlib import Path

    table = _table()
    doc = (Path(__file__).resolve().parents[2] / "docs" / "bad_input.md").read_text()
    documented = [ln for ln in doc[doc.index(table.LIBRARY_HEADING):].splitlines()
                  if ln.startswith("| `")]
    now = [ln for ln in table.library_table(table.run_library_cases()).splitlines()
           if ln.startswith("| `")]
    assert len(documented) == len(now) == len(table.LIBRARY_CASES)
    number = re.compile(r"(?<![\w.])[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")
    for d, g in zip(documented, now):
        assert number.sub("#", d) == number.sub("#", g), f"\n  doc: {d}\n  now: {g}"
        for a, b in zip(number.findall(d), number.findall(g)):
            assert float(a) == pytest.approx(float(b), rel=1e-6), f"\n  doc: {d}\n  now: {g}"


def test_kill_between_the_two_renames_is_recovered(tmp_path):
    """A run killed after moving the previous folder aside and before moving its own into
    place: the next check puts the previous folder back; leftovers of dead runs go."""
    import subprocess
    import sys

    from mbs_clearance._io import OutputDir, check_output_dir, verify_run_folder

    target = tmp_path / "out"
    with OutputDir(target, "test") as staged:
        (staged.path / "a.txt").write_text("previous run")
        staged.commit()
    before = verify_run_folder(target)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()
    target.rename(tmp_path / f".out.old-{dead}-abcdef")
    (tmp_path / f".out.partial-{dead}-abcdef").mkdir()
    (tmp_path / f".t.npz.partial-{dead}-xyz.npz").write_bytes(b"half")
    check_output_dir(target, "--out")
    from mbs_clearance._io import check_output_file

    check_output_file(tmp_path / "t.npz", "--out")
    assert verify_run_folder(target) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_stress_json_is_stamped_checked_first_and_replaced_only_if_ours(tmp_path, monkeypatch,
                                                                      capsys):
    """`stress --json` on one real (short) case: the file holds the run's rows under a run
    stamp; a second run replaces it; a user's JSON file is refused unless --force."""
    import validation.stress as stress
    from mbs_clearance._io import RUN_KEY

    case = stress.StressCase("paper case, 1 revolution", SliderCrank(), revolutions=1)
    for module in _plugin_modules("stress"):      # the one the CLI runs, too
        monkeypatch.setattr(module, "stress_cases", lambda quick: [case])
    out = tmp_path / "s.json"
    assert main(["stress", "--json", str(out)]) == 0
    first = json.loads(out.read_text())
    assert first[RUN_KEY]["command"] == "stress"
    reference = stress.run_case(case)
    assert [r["case"] for r in first["rows"]] == [reference["case"]]
    assert first["rows"][0]["peak_last_revolution"] == pytest.approx(
        reference["peak_last_revolution"], rel=1e-12)
    assert main(["stress", "--json", str(out)]) == 0
    assert json.loads(out.read_text())[RUN_KEY]["run_id"] != first[RUN_KEY]["run_id"]
    user = tmp_path / "mine.json"
    user.write_text("{}")
    with pytest.raises(SystemExit) as exc:
        main(["stress", "--json", str(user)])
    assert exc.value.code == 2 and "pass --force" in capsys.readouterr().err
    assert user.read_text() == "{}"
    assert main(["stress", "--json", str(user), "--force"]) == 0
    assert "will be overwritten (--force)" in capsys.readouterr().err
    assert RUN_KEY in json.loads(user.read_text())


def test_warnings_during_a_command_are_one_line(tmp_path):
    """A warning raised while a command runs is shown as `PROG: warning: MESSAGE` (a real
    interpreter: pytest records warnings itself)."""
    import subprocess
    import sys

    code = ("import warnings\n"
            "from mbs_clearance.cli import run_command\n"
            "def work(args):\n"
            "    warnings.warn('penetration 9212 x the clearance\\nreduce the speed')\n"
            "    return 0\n"
            "raise SystemExit(run_command('mbs-clearance simulate', work, None))\n")
    proc = subprocess.run([sys.executable, "-W", "always", "-c", code], capture_output=True,
                          text=True, cwd=tmp_path, env=_env())
    assert proc.returncode == 0
    assert proc.stderr == ("mbs-clearance simulate: warning: penetration 9212 x the "
                           "clearance; reduce the speed\n")


# ------------------------------------------------------------------ named cases, descriptions
def _linkage(argv):
    from mbs_clearance.cli import build_parser, linkage_from_args

    return linkage_from_args(build_parser().parse_args(["simulate", *argv]))


def test_help_lists_the_named_cases(capsys):
    from mbs_clearance.model.cases import CASES

    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--help-all"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    epilog = out[out.index("named cases"):]
    for name in CASES:
        assert f"  {name}: " in epilog


def test_case_and_overrides_from_the_command_line():
    from mbs_clearance.model.cases import four_bar, paper_slider_crank

    assert _linkage([]) is None                       # the SliderCrank options apply
    assert _linkage(["--case", "four_bar"]) == four_bar()
    assert _linkage(["--case", "four_bar", "--set", "clearance=1e-7", "--set",
                     "crank_speed = 12.5", "--set", "coupler_inertia=none",
                     "--set", "contact_model=hunt_crossley"]) == four_bar(
        clearance=1e-7, crank_speed=12.5, contact_model="hunt_crossley")
    assert _linkage(["--case", "paper_slider_crank", "--set", "journal_radius=0.00995"]) == \
        paper_slider_crank(journal_radius=0.00995)


@pytest.mark.parametrize("suffix", [".json", ".toml"])
def test_description_file_json_and_toml(tmp_path, suffix):
    from mbs_clearance.model.cases import slider_crank_two_clearances

    linkage = slider_crank_two_clearances(coupler_slider_clearance=2e-5)
    path = tmp_path / f"mech{suffix}"
    if suffix == ".json":
        path.write_text(json.dumps(linkage.to_dict()))
    else:
        path.write_text(_toml(linkage.to_dict()))
    assert _linkage(["--description", str(path)]) == linkage


def _toml(data, prefix=""):
    """A minimal TOML writer for Linkage.to_dict's form (tables, arrays of tables)."""
    def value(v):
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{json.dumps(k)} = {value(x)}" for k, x in v.items()) + "}"
        return repr(float(v)) if isinstance(v, float) else str(v)

    lines, tables = [], []
    for k, v in data.items():
        if v is None:
            continue
        if isinstance(v, list) and v and isinstance(v[0], dict):
            tables.append((k, v))
        elif isinstance(v, dict) and k == "drive":
            tables.append((k, [v]))
        else:
            lines.append(f"{k} = {value(v)}")
    for k, items in tables:
        for item in items:
            lines.append(f"[[{k}]]" if k != "drive" else "[drive]")
            lines += [f"{kk} = {value(vv)}" for kk, vv in item.items() if vv is not None]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("argv,message", [
    (["--case", "nope"], "argument --case: invalid choice: 'nope'"),
    (["--case", "four_bar", "--description", "x.json"],
     "argument --description: not allowed with argument --case"),
    (["--set", "clerance=1e-4"], "--set clerance: not a field of the paper's slider-crank"),
    (["--case", "four_bar", "--set", "clearance"], "argument --set: must be NAME=VALUE"),
    (["--case", "four_bar", "--set", "clerance=1e-4"],
     "four_bar: unknown override(s) ['clerance']; allowed: ['bearing_radius', 'clearance'"),
    (["--case", "four_bar", "--set", "clearance=-1"], "four_bar: clearance must be > 0 m"),
    (["--case", "four_bar", "--set", "clearance=1e-4", "--set", "clearance=2e-4"],
     "--set clearance given twice"),
    (["--case", "four_bar", "--journal-radius", "0.05"],
     "four_bar: unknown override(s) ['journal_radius']"),
    (["--case", "four_bar", "--clearance", "1e-4", "--set", "clearance=2e-4"],
     "clearance given twice"),
    (["--description", "/nonexistent.json"], "cannot read linkage file '/nonexistent.json'"),
    (["--case", "four_bar", "--plot", "f.png"], "--plot draws the paper's slider-crank only"),
])
def test_case_and_description_errors_are_one_line(argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["simulate", *argv])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_packaging_installs_no_generic_top_level_package_and_version_from_metadata(capsys):
    """A wheel holds mbs_clearance and mbs_clearance_validation only (no top-level
    `validation` to collide with other projects); the plugins load under the installed name;
    --version and __version__ come from the package metadata (one place: pyproject)."""
    from importlib.metadata import entry_points, version
    from pathlib import Path

    import tomllib

    import mbs_clearance
    from mbs_clearance.cli import PLUGIN_GROUP

    cfg = tomllib.loads((Path(__file__).parents[2] / "pyproject.toml").read_text())
    tops = {p.split(".")[0] for p in cfg["tool"]["setuptools"]["packages"]}
    assert tops == {"mbs_clearance", "mbs_clearance_validation"}
    eps = entry_points(group=PLUGIN_GROUP)
    assert {ep.name for ep in eps} >= {"compare", "stress", "bench", "report"}
    for ep in eps:
        assert ep.value.startswith("mbs_clearance_validation."), ep.value
        assert callable(ep.load())
    assert mbs_clearance.__version__ == version("mbs-clearance") == cfg["project"]["version"]
    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out.strip() == f"mbs-clearance {cfg['project']['version']}"


# ------------------------------------------------------------------ help, outputs, start-up
def _help_entries(text):
    """--help's option entries, each joined to one line."""
    import re

    entries, current = [], None
    for line in text.splitlines():
        if re.match(r"^  -", line):
            current = [line]
            entries.append(current)
        elif current is not None and re.match(r"^\s{6,}\S", line):
            current.append(line)
        else:
            current = None
    return [" ".join(" ".join(e).split()) for e in entries]


def _subcommands():
    from importlib.metadata import entry_points

    from mbs_clearance.cli import BUILTIN, PLUGIN_GROUP

    return list(BUILTIN) + sorted(ep.name for ep in entry_points(group=PLUGIN_GROUP))


@pytest.mark.parametrize("command", _subcommands())
def test_help_shows_every_default_and_choice(command, capsys):
    """Every option that takes a value says its default (or that it is required) and lists
    its choices in `COMMAND --help-all`."""
    import argparse

    with pytest.raises(SystemExit):
        main([command, "--help-all"])
    entries = _help_entries(capsys.readouterr().out)
    from mbs_clearance.cli import build_parser

    parser = build_parser(command)
    sub = next(a for a in parser._actions
               if isinstance(a, argparse._SubParsersAction)).choices[command]
    checked = 0
    for action in sub._actions:
        if not action.option_strings or action.nargs == 0:
            continue
        entry = next(e for e in entries if e.split(" ")[0].rstrip(",") in action.option_strings)
        assert "default" in entry or "(required)" in entry, entry
        for choice in action.choices or ():
            assert str(choice) in entry, (entry, choice)
        checked += 1
    assert checked >= 1


def test_help_shows_engineering_units(capsys):
    with pytest.raises(SystemExit):
        main(["simulate", "--help-all"])
    text = " ".join(capsys.readouterr().out.split())
    for shown in ("(default 5000 rpm = 523.599)", "(default 207 GPa = 2.07e+11)",
                  "(default 9.99 mm = 0.00999)", "lankarani_nikravesh; one of"):
        assert shown in text, shown


def _help_page(capsys, *argv) -> str:
    with pytest.raises(SystemExit) as exc:
        main(list(argv))
    assert exc.value.code == 0
    return capsys.readouterr().out


def _options_of(page: str) -> list[str]:
    return [e.split(" ")[0].rstrip(",") for e in _help_entries(page)]


@pytest.mark.parametrize("command", _subcommands())
def test_short_help_shows_the_common_options_and_help_all_every_one(command, capsys):
    """`COMMAND --help` lists the common options and says how many more `--help-all`
    shows; `--help-all` lists every option of the parser once, the common ones first, each
    with a help text."""
    import argparse

    from mbs_clearance.cli import build_parser

    short = _help_page(capsys, command, "--help")
    full = _help_page(capsys, command, "--help-all")
    parser = build_parser(command)
    sub = next(a for a in parser._actions
               if isinstance(a, argparse._SubParsersAction)).choices[command]
    every = [a.option_strings[0] for a in sub._actions if a.option_strings]
    listed = _options_of(full)
    assert sorted(listed) == sorted(every), (listed, every)
    common = _options_of(short)
    assert listed[:len(common)] == common            # the common options first
    hidden = len(listed) - len(common)
    if hidden:
        assert f"{hidden} more options" in " ".join(short.split())
        assert f"mbs-clearance {command} --help-all" in " ".join(short.split())
    for entry in _help_entries(full):                # every option says what it does
        assert len(entry.split()) >= 3, entry


def test_short_help_of_simulate_fits_a_screen(capsys):
    short = _help_page(capsys, "simulate", "--help")
    full = _help_page(capsys, "simulate", "--help-all")
    assert len(short.splitlines()) <= 55 < len(full.splitlines())
    assert "--crank-length" not in short and "--crank-length" in full


@pytest.mark.parametrize("command", _subcommands())
def test_every_mechanism_option_shows_its_unit(command, capsys):
    """The mechanism options name their SI unit ("in kg"), or say they are dimensionless;
    no option reads "- in -"."""
    from mbs_clearance.model.mechanism import PARAMETER_INFO

    entries = {e.split(" ")[0]: e for e in _help_entries(_help_page(capsys, command,
                                                                    "--help-all"))}
    assert not any(" in - " in e or "- in" in e for e in entries.values())
    for name, (_, unit, _) in PARAMETER_INFO.items():
        entry = entries.get("--" + name.replace("_", "-"))
        if entry is None:
            continue
        if unit not in ("-", ""):
            assert f" in {unit} (default" in entry, entry
        elif name not in ("contact_model", "friction_law"):
            assert "dimensionless" in entry, entry


def _wrote(err):
    """The files a command says it wrote: `wrote PATH (WHAT)` lines."""
    import re
    from pathlib import Path

    return [Path(m.group(1)) for m in re.finditer(r"^wrote (.+?) \(.+\)$", err, re.M)]


def test_simulate_says_what_it_wrote_and_marks_the_start_up(tmp_path, capsys):
    out, fig = tmp_path / "t.npz", tmp_path / "f.png"
    assert main(["simulate", "--revolutions", "2", "--out", str(out), "--plot",
                 str(fig)]) == 0
    captured = capsys.readouterr()
    assert _wrote(captured.err) == [out, fig]
    assert out.is_file() and fig.is_file()
    rows = captured.out.splitlines()
    assert rows[1].split()[0] == "1*" and "start-up transient" in captured.err
    assert rows[1].split()[2] == "N" and rows[1].split()[4:6] == ["N", "m"]
    assert "the paper reports revolution 4" in captured.err
    # six significant digits: the default run's stated relative accuracy is 1e-5
    assert len(rows[1].split()[1].replace(".", "").lstrip("0")) <= 6
    # without --out/--plot nothing is written (as its help says)
    before = sorted(tmp_path.iterdir())
    assert main(["simulate", "--revolutions", "1"]) == 0
    assert _wrote(capsys.readouterr().err) == [] and sorted(tmp_path.iterdir()) == before


def test_a_named_case_is_not_said_to_be_the_papers(capsys):
    assert main(["simulate", "--case", "four_bar", "--revolutions", "1"]) == 0
    captured = capsys.readouterr()
    assert "start-up transient" in captured.err and "paper" not in captured.err
    peak = captured.out.splitlines()[1].split()[1]
    assert 1 <= len(peak.replace(".", "").lstrip("0")) <= 6


def test_ideal_joint_table_has_no_contact_force(capsys):
    assert main(["simulate", "--revolutions", "1", "--backend", "ideal"]) == 0
    captured = capsys.readouterr()
    out = captured.out
    assert "contact" not in out and "max pivot_force:crank_pivot" in out
    # no journal, no start-up transient: no footnote about the journal's start
    assert out.splitlines()[1].split()[0] == "1" and "journal" not in captured.err
    # the ideal-joint peak printed matches the closed form's
    peak = float(out.splitlines()[1].split()[1])
    assert peak == pytest.approx(peak_base_force(SliderCrank(), 1, backend="ideal"), rel=1e-6)


def test_sensitivity_writes_what_it_says(tmp_path, capsys):
    out = tmp_path / "sens"
    assert main(["sensitivity", "--parameters", "crank_length,restitution", "--revolutions",
                 "1", "--out", str(out)]) == 0
    wrote = _wrote(capsys.readouterr().err)
    assert wrote[0] == out / "sensitivities.npz" and len(wrote) >= 3
    assert all(p.is_file() and p.parent == out for p in wrote)
    written = {p.name for p in out.iterdir()} - {"manifest.json"}
    assert written == {p.name for p in wrote}


def test_sensitivity_of_a_named_case(capsys):
    """`sensitivity --case`: the paper case as a description, by the generated model's DDM,
    prints the same mean |S| as the hand-derived SliderCrank DDM for the same parameter."""
    from mbs_clearance.analysis.sensitivity import summary_sensitivities

    assert main(["sensitivity", "--case", "paper_slider_crank", "--parameters",
                 "slider.mass,coupler_slider.restitution", "--revolutions", "2"]) == 0
    rows = capsys.readouterr().out.splitlines()[2:4]
    assert [r.split()[0] for r in rows] == ["slider.mass", "coupler_slider.restitution"]
    ref = summary_sensitivities(SliderCrank(), ("slider_mass", "restitution"), 2).summary()
    for row, r in zip(rows, ref):
        assert float(row.split()[-3]) == pytest.approx(r["mean_abs_normalized"], rel=2e-3)


def test_import_loads_only_what_is_needed():
    """`import mbs_clearance` and building the CLI's parser for a built-in command load no
    compiled model, no scipy.integrate or scipy.interpolate, no exudyn, no matplotlib, no
    validation plugin; the top-level --help lists the plugins without importing their
    modules."""
    import subprocess
    import sys
    from pathlib import Path

    code = ("import sys, mbs_clearance; a = set(sys.modules); "
            "from mbs_clearance.cli import build_parser; build_parser('simulate'); "
            "b = set(sys.modules); print(repr((sorted(a), sorted(b))))")
    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True,
                         text=True, check=True).stdout
    after_import, after_parser = eval(out.strip().splitlines()[-1])  # noqa: S307 - own output
    heavy = ("scipy.integrate", "scipy.interpolate", "matplotlib", "exudyn",
             "mbs_clearance.generate.c_loader", "mbs_clearance.solve.reduced",
             "mbs_clearance.ddm", "mbs_clearance_validation", "sympy", "pygad", "xarray")
    for modules in (after_import, after_parser):
        assert not [m for m in modules if m.startswith(heavy)]
    # the top-level --help lists the plugin subcommands from their light declarations
    code = ("import sys; from mbs_clearance.cli import build_parser; "
            "p = build_parser(None); print(p.format_help()); print(repr(sorted(sys.modules)))")
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True,
                         text=True, check=True).stdout
    listing, modules = out.strip().rsplit("\n", 1)
    from importlib.metadata import entry_points

    from mbs_clearance.cli import PLUGIN_GROUP

    for ep in entry_points(group=PLUGIN_GROUP):
        assert ep.name in listing and ep.load().help in listing
    light = ("mbs_clearance_validation", "mbs_clearance_validation.commands")
    assert not [m for m in eval(modules) if m.startswith(heavy) and m not in light]  # noqa: S307
    # the public names still resolve (lazily) and __all__ is complete
    import mbs_clearance

    for name in mbs_clearance.__all__:
        assert getattr(mbs_clearance, name) is not None
    assert set(mbs_clearance.__all__) <= set(dir(mbs_clearance))


def test_library_messages_go_through_logging(caplog, capsys, tmp_path, monkeypatch):
    """The library's messages are records of the logger "mbs_clearance" (silenced like any
    logger); the CLI prints them as `PROG: MESSAGE` while a command runs."""
    import logging

    from mbs_clearance.cli import run_command
    from mbs_clearance.core import build

    monkeypatch.setenv("MBS_CLEARANCE_CACHE_DIR", str(tmp_path))
    source = "int mbs_log_probe(void) { return %d; }"
    # a first build announces itself (INFO), with the compiler's estimate once one is on record
    with caplog.at_level(logging.INFO, logger="mbs_clearance"):
        build.build("log-probe", [("probe.c", source % 1)])
    (record,) = caplog.records
    assert record.name == "mbs_clearance" and record.levelno == logging.INFO
    assert re.match(r"compiling log-probe \(first use only(, about \d+ s)?\)$",
                    record.getMessage())
    caplog.clear()
    logging.getLogger("mbs_clearance").setLevel(logging.WARNING)       # a user silences it
    try:
        # a cache without an estimate on record: the build would announce itself
        monkeypatch.setenv("MBS_CLEARANCE_CACHE_DIR", str(tmp_path / "other"))
        with caplog.at_level(logging.WARNING, logger="mbs_clearance"):
            build.build("log-probe", [("probe.c", source % 2)])
        assert not caplog.records
    finally:
        logging.getLogger("mbs_clearance").setLevel(logging.NOTSET)

    def command(args):
        logging.getLogger("mbs_clearance.analysis.sensitivity").warning("coarse result")
        return 0

    assert run_command("mbs-clearance test", command, None) == 0
    assert capsys.readouterr().err == "mbs-clearance test: coarse result\n"


@pytest.mark.parametrize("case", [None, "paper_slider_crank"])
def test_lyapunov_prints_the_exponent_with_units_and_its_sign(case, capsys):
    """`lyapunov` prints the Python function's exponent for the same inputs (the paper's
    SliderCrank by default, or a --case's Linkage), per revolution and in 1/s, with its
    uncertainty, and its verdict's meaning: negative at the paper's design (period-1 motion,
    docs/regimes.md)."""
    import re

    from mbs_clearance import lyapunov_exponent
    from mbs_clearance.model import cases

    argv = ["lyapunov", "--revolutions", "16", "--transient", "8"]
    argv += [] if case is None else ["--case", case]
    assert main(argv) == 0
    out = capsys.readouterr().out
    m = re.search(r"exponent of .+?: (\S+) \+- (\S+) per revolution \((\S+) \+- \S+ 1/s\), "
                  r"the mean over revolutions 9-16", out)
    assert m, out
    mech = SliderCrank() if case is None else cases.CASES[case]()
    ref = lyapunov_exponent(mech, revolutions=16, transient=8)
    assert float(m.group(1)) == pytest.approx(ref.per_revolution, rel=1e-3)
    assert float(m.group(2)) == pytest.approx(ref.uncertainty, rel=1e-2)
    assert float(m.group(3)) == pytest.approx(ref.per_second, rel=1e-3)
    assert ref.interval[1] < -0.1 and "verdict: negative" in out and "converge" in out
    assert f"it shrinks e-fold every {1 / abs(ref.per_revolution):.3g} revolutions" in out
    # the regime of the same revolutions by the map's rule: the section repeats each turn
    assert (ref.regime, ref.period) == ("period_1", 1)
    assert "regime of revolutions 9-16 (the regime map's rule): period-1" in out


@pytest.mark.parametrize("argv, message", [
    (["--revolutions", "4", "--transient", "4"],
     "--transient must be between 0 and --revolutions - 1 (3); got 4"),
    (["--revolutions", "1"], "argument --revolutions: must be an integer >= 2; got 1"),
    (["--memory", "keep"], "argument --memory: invalid choice: 'keep'"),
    (["--case", "four_bar", "--journal-radius", "0.05"],
     "four_bar: unknown override(s) ['journal_radius']"),
])
def test_lyapunov_bad_input_is_one_line_before_any_run(argv, message, capsys, monkeypatch):
    import importlib

    lyap = importlib.import_module("mbs_clearance.analysis.lyapunov")
    monkeypatch.setattr(lyap, "lyapunov_exponent", lambda *a, **k: pytest.fail("ran"))
    with pytest.raises(SystemExit) as exc:
        main(["lyapunov", *argv])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


def test_simulate_accuracy_prints_the_runs_estimate(capsys):
    """`simulate --accuracy 1e-6` prints the Python function's peaks at that request and
    the run's own error estimate (stderr); with --rtol too it is refused in one line."""
    from mbs_clearance import simulate

    assert main(["simulate", "--revolutions", "1", "--accuracy", "1e-6"]) == 0
    captured = capsys.readouterr()
    peak1 = float(captured.out.splitlines()[1].split()[1])
    traj = simulate(SliderCrank(), 1, accuracy=1e-6)
    assert peak1 == pytest.approx(traj.peaks[0], abs=0.01)
    assert (f"estimated relative error of the peaks: {traj.stats['error_estimate']:.2g} "
            "(requested 1e-06, met") in captured.err
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--accuracy", "1e-6", "--rtol", "1e-8"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "give accuracy or rtol, not both" in err, err


def test_mechanism_options_are_aliases_of_set(tmp_path):
    """One option system: a SliderCrank option, --clearance and --set NAME=VALUE give the
    same design, for the paper's slider-crank, a named case and a description."""
    from mbs_clearance import SliderCrank
    from mbs_clearance.cli import build_parser, linkage_from_args, mechanism_from_args
    from mbs_clearance.model.cases import four_bar

    parse = build_parser().parse_args
    paper = SliderCrank()
    by_flag = mechanism_from_args(parse(["simulate", "--crank-length", "0.06",
                                         "--clearance", "2e-5"]))
    by_set = mechanism_from_args(parse(["simulate", "--set", "crank_length=0.06",
                                        "--set", "clearance=2e-5"]))
    assert by_flag == by_set
    assert by_flag.crank_length == 0.06
    assert by_flag.journal_radius == pytest.approx(paper.bearing_radius - 2e-5, abs=1e-15)
    case = linkage_from_args(parse(["simulate", "--case", "four_bar", "--coupler-length",
                                    "4.2", "--clearance", "1e-4"]))
    same = linkage_from_args(parse(["simulate", "--case", "four_bar", "--set",
                                    "coupler_length=4.2", "--set", "clearance=1e-4"]))
    assert case.to_dict() == same.to_dict() == four_bar(coupler_length=4.2,
                                                          clearance=1e-4).to_dict()
    assert case.overrides == {"coupler_length": 4.2, "clearance": 1e-4}
    path = tmp_path / "four_bar.json"
    path.write_text(__import__("json").dumps(four_bar().to_dict()))
    desc = linkage_from_args(parse(["simulate", "--description", str(path), "--set",
                                    "coupler.mass=1.5", "--clearance", "2e-4"]))
    assert desc.parameter_value("coupler.mass") == 1.5
    assert min(j.clearance for j in desc.clearance_joints) == pytest.approx(2e-4, rel=1e-12)
    assert max(j.clearance for j in desc.clearance_joints) == pytest.approx(2e-4, rel=1e-12)


def test_optimize_prints_its_internals_only_with_verbose(tmp_path, capsys):
    """The normal output names no executor, refinement method or KKT check; --verbose adds
    them."""
    argv = ["optimize", "--seed", "5", "--population", "4", "--generations", "1",
            "--workers", "1", "--no-refine", "--no-progress", "--out"]
    assert main(argv + [str(tmp_path / "a")]) == 0
    normal = capsys.readouterr().out
    assert "| optimum (ours) |" in normal
    for internal in ("Executor", "workers)", "evaluated on", "l-bfgs-b", "KKT"):
        assert internal not in normal, internal
    assert main(argv + [str(tmp_path / "b"), "--verbose"]) == 0
    verbose = capsys.readouterr().out
    assert "evaluated on " in verbose and "; refinement: none" in verbose


def test_orbit_numbers_print_with_units_and_as_modulus_and_angle():
    from mbs_clearance.cli import _coordinate, _multiplier

    assert _multiplier(0.5 + 0.5j) == "|mu| = 0.707107  angle +45.0 deg"   # sqrt(1/2), 45 deg
    assert _multiplier(-0.9) == "|mu| = 0.9  angle +180.0 deg"
    assert _multiplier(1.08e-14 + 6.3e-15j) == "|mu| = 1e-14 (zero to round-off)"
    assert _coordinate("coupler.angle", 0.25) == " 0.25 rad"
    assert _coordinate("coupler.angle_rate", -3.5) == "-3.5 rad/s"
    assert _coordinate("slider.x", 0.16999123456) == " 0.16999123 m"
    assert _coordinate("disc.y_rate", 1e-3) == " 0.001 m/s"
