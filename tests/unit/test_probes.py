"""What a hostile or careless user tries, kept as tests that run in bounded time.

- sizes: every count and duration option of every command at 1e9, -1, 0, nan and inf is
  refused (exit status 2) by a message naming the option, before any run starts (the
  runs are replaced by a function that fails the test);
- hostile names: a body or joint named after a key of the description is refused at load;
- failed and empty runs: a study with failed runs exits 1 unless --keep-going; a force far
  above the mechanism's load scale is warned about;
- outputs: a full disk under --out is found before the work, a failed write names the
  file, a damaged map.nc is named, SIGTERM leaves no partial folder.

(The compiled-code cache's probes: tests/unit/test_core_build.py.)
"""

from __future__ import annotations

import errno
import json
import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mbs_clearance import SliderCrank
from mbs_clearance._io import atomic_file
from mbs_clearance._warnings import PhysicsWarning
from mbs_clearance.cli import (
    ABSURD_FORCE,
    load_scale,
    main,
    refuse_empty,
    warn_absurd_forces,
)
from mbs_clearance.model import cases
from mbs_clearance.model.linkage import RESERVED_NAMES, Linkage

INPUTS = '{"crank_length": {"band": [0.05, 5e-4]}}'

# ---------------------------------------------------------------- sizes

#: (command line before the option, option, smallest allowed value): every count and
#: duration option; the command line is one that would run if the option were fine
SIZE_OPTIONS = [
    ("simulate", "--revolutions", 1),
    ("simulate --case four_bar --revolutions 1", "--settled", 1),
    ("simulate --case flores_translational_slider_crank", "--duration", 0.0),
    ("simulate --case flores_translational_slider_crank --duration 0.1", "--window", 0.0),
    ("simulate --backend exudyn", "--step-size", 0.0),
    ("sensitivity", "--revolutions", 1),
    ("sensitivity --case four_bar --revolutions 2", "--settled", 1),
    ("sensitivity --case flores_translational_slider_crank", "--duration", 0.0),
    ("sensitivity --method fd --backend exudyn", "--step-size", 0.0),
    ("lyapunov", "--revolutions", 2),
    ("lyapunov --case flores_translational_slider_crank", "--duration", 0.0),
    ("animate", "--frames", 2),
    ("animate", "--revolutions", 1),
    ("bench --quick --no-exudyn", "--repeats", 1),
    ("map --sweep clearance=1e-5:1e-4:1000", "--workers", 1),
    ("map --sweep clearance=1e-5:1e-4:3", "--revolutions", 2),
    ("map --sweep clearance=1e-5:1e-4:3", "--keep", 1),
    ("map --sweep clearance=1e-5:1e-4:3", "--max-period", 1),
    ("compare", "--revolutions", 1),
    ("compare", "--step-size", 0.0),
    ("optimize", "--revolution", 1),
    ("optimize --case flores_translational_slider_crank --gene crank.mass=0.03:0.05",
     "--duration", 0.0),
    ("optimize", "--population", 2),
    ("optimize", "--generations", 1),
    ("orbits", "--settle", 0),
    ("orbits", "--period", 1),
    ("tolerance inputs.json --sobol 0 --monte-carlo 8", "--revolution", 1),
    ("tolerance inputs.json --sobol 0 --monte-carlo 8 --case "
     "flores_translational_slider_crank", "--duration", 0.0),
    ("tolerance inputs.json", "--sobol", 0),
    ("tolerance inputs.json --sobol 0", "--monte-carlo", 0),
]
HUGE = {int: "1000000000", float: "1e9"}


def _size_cases():
    for prefix, option, low in SIZE_OPTIONS:
        kind = type(low)
        for value in (HUGE[kind], "-1", "0", "nan", "inf"):
            if value == "0" and low == 0:
                continue                    # allowed (e.g. --settle 0, --sobol 0)
            yield pytest.param(prefix, option, value, id=f"{prefix.split()[0]} {option} {value}")


@pytest.fixture
def no_runs(monkeypatch):
    """Every way a command starts a run fails the test (exit status 1, not 2)."""
    import mbs_clearance.solve.linkage_model as lm
    import mbs_clearance.solve.reduced as reduced
    import mbs_clearance.solve.simulate as sim
    import mbs_clearance.studies.tolerance as tol

    def started(*args, **kw):
        raise RuntimeError("a run started")

    for module, name in ((sim, "simulate"), (lm, "run"), (lm, "settled_start"),
                         (reduced, "run"), (tol, "_mechanism_output")):
        monkeypatch.setattr(module, name, started)


def cli(argv, capsys) -> tuple[int, str]:
    """(exit status, stderr) of `mbs-clearance ARGV` run in this process."""
    try:
        status = main(argv)
    except SystemExit as exc:
        status = exc.code
    return status, capsys.readouterr().err


@pytest.mark.parametrize("prefix, option, value", list(_size_cases()))
def test_every_size_option_is_refused_naming_it_before_any_run(prefix, option, value,
                                                               tmp_path, monkeypatch,
                                                               capsys, no_runs):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "inputs.json").write_text(INPUTS)
    status, err = cli([*prefix.split(), option, value], capsys)
    assert status == 2, err
    line = err.strip().splitlines()[-1]
    # the option named, or the library's keyword of the same name (workers=, population)
    assert re.search(re.escape(option) + r"|\b" + re.escape(option[2:].replace("-", "_"))
                     + r"\b", line), line
    assert "a run started" not in err and "internal error" not in err


def test_messages_name_the_option_not_another_one(tmp_path, monkeypatch, capsys, no_runs):
    monkeypatch.chdir(tmp_path)
    status, err = cli(["map", "--sweep", "clearance=1e-5:1e-4:1000", "--workers",
                       "1000000000", "--out", "m"], capsys)
    assert status == 2 and "workers=1000000000" in err and "revolutions=100:" not in err
    status, err = cli(["compare", "--step-size", "1e9"], capsys)
    assert status == 2 and "--step-size 1e+09 s is longer than a revolution" in err
    assert "full revolution" not in err
    # a step that fits: the estimate grows as revolutions / step (closed form)
    from mbs_clearance.cli import check_run_size

    paper = SliderCrank()
    steps = check_run_size(paper, "--revolutions", 4, backend="exudyn", step_size=1e-5)
    assert steps == math.ceil(4 * paper.period / 1e-5)


# ---------------------------------------------------------------- hostile names


def _renamed(name: str, new: str) -> dict:
    text = json.dumps(cases.four_bar().to_dict())
    assert f'"{name}"' in text
    # the item, the references to it and the dotted keys naming it ("coupler.angle")
    return json.loads(re.sub(f'"{name}(?=[".])', f'"{new}', text))


@pytest.mark.parametrize("reserved", RESERVED_NAMES[1:])
@pytest.mark.parametrize("item", ["coupler", "crank_coupler"])
def test_an_item_named_after_a_description_key_is_refused_at_load(item, reserved):
    kind = "body" if item == "coupler" else "joint"
    Linkage.from_dict(_renamed(item, "coupler2"))     # the control: another name loads
    with pytest.raises(ValueError, match=f"{kind} name '{reserved}' is reserved: "):
        Linkage.from_dict(_renamed(item, reserved))


def test_the_key_a_reserved_name_would_shadow_is_the_descriptions(tmp_path, capsys):
    """What the refusal prevents: 'gravity' is the linkage's gravity, so a body named
    gravity would have its mass set as g; on the command line the file is refused."""
    four = cases.four_bar()
    assert four.with_parameter("gravity", 0.21).gravity == 0.21
    path = tmp_path / "gravity.json"
    path.write_text(json.dumps(_renamed("coupler", "gravity")))
    status, err = cli(["simulate", "--description", str(path), "--set", "gravity.mass=0.21"],
                      capsys)
    assert status == 2 and "body name 'gravity' is reserved" in err


# ---------------------------------------------------------------- failed and absurd runs


def test_a_study_with_failed_runs_exits_1_unless_keep_going(tmp_path, monkeypatch, capsys):
    """Runs of the designs with a crank longer than nominal fail (RuntimeError, as a failed
    integration), the others give the ideal joints' closed-form peak: the study counts
    the failures, prints and writes its results, and exits 1; with --keep-going 0."""
    import mbs_clearance.studies.tolerance as tol
    from mbs_clearance.solve.simulate import simulate

    def output(mech, task):
        if mech.crank_length > 0.05:
            raise RuntimeError("integration failed: step size underflow")
        return simulate(mech, task.revolution, backend="ideal").max_base_force(
            task.revolution), None, False, False

    monkeypatch.setattr(tol, "_mechanism_output", output)
    # the samples are the ideal joints' peaks: the check of the nominal one against the
    # reduced model at the default accuracy is not what this test is about
    monkeypatch.setattr(tol, "_nominal_accuracy_note", lambda problem: [])
    monkeypatch.chdir(tmp_path)
    (tmp_path / "inputs.json").write_text(INPUTS)
    argv = ["tolerance", "inputs.json", "--sobol", "0", "--monte-carlo", "16", "--workers",
            "1", "--no-progress"]
    status, err = cli(argv, capsys)
    result = json.loads((tmp_path / "tolerance" / "result.json").read_text())
    failed = result["counts"]["failed"]
    assert 0 < failed < 16                          # a band around 0.05: both kinds
    assert status == 1 and f"{failed} of 16 runs failed" in err and "--keep-going" in err
    status, err = cli([*argv, "--keep-going"], capsys)
    assert status == 0, err


@pytest.mark.parametrize("option, value", [("--allowable", "-1"), ("--rtol", "0.5"),
                                           ("--rtol", "1e9")])
def test_study_options_every_run_would_fail_on_are_refused(tmp_path, monkeypatch, capsys,
                                                          no_runs, option, value):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "inputs.json").write_text(INPUTS)
    status, err = cli(["tolerance", "inputs.json", option, value], capsys)
    assert status == 2 and option in err, err


def test_a_force_far_above_the_load_scale_is_warned_about_and_an_empty_run_refused():
    paper = SliderCrank()
    # the load scale in closed form: masses times (g + w^2 x length)
    w2, g = paper.crank_speed**2, paper.gravity
    assert load_scale(paper) == pytest.approx(
        paper.crank_mass * (g + w2 * paper.crank_length)
        + paper.coupler_mass * (g + w2 * paper.coupler_length) + paper.slider_mass * g)
    from mbs_clearance.solve.simulate import simulate

    traj = simulate(paper, 2, backend="ideal")      # closed form: no warning
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_absurd_forces(paper, traj)
    import dataclasses

    traj = dataclasses.replace(traj, peaks=np.asarray(traj.peaks) * 2 * ABSURD_FORCE)
    with pytest.warns(PhysicsWarning, match="times the mechanism's load scale"):
        warn_absurd_forces(paper, traj)
    # a run that returned no revolution: an error, not an empty table
    refuse_empty(traj)
    with pytest.raises(RuntimeError, match="no complete revolution"):
        refuse_empty(dataclasses.replace(traj, peaks=np.empty(0)))


# ---------------------------------------------------------------- outputs


def test_a_full_disk_under_out_is_found_before_the_work(tmp_path, monkeypatch, capsys,
                                                        no_runs):
    monkeypatch.chdir(tmp_path)

    class Full:
        f_bavail, f_frsize = 10, 4096

    monkeypatch.setattr(os, "statvfs", lambda path: Full)
    status, err = cli(["sensitivity", "--out", "sens"], capsys)
    assert status == 2 and "--out" in err and "full disk" in err


def _fill(folder: Path) -> None:
    """Fill the file system of `folder` (a small tmpfs) to the last byte."""
    try:
        with open(folder / "filler", "wb") as f:
            while True:
                f.write(b"x" * 4096)
                f.flush()
    except OSError as exc:
        assert exc.errno == errno.ENOSPC


def test_a_full_tmpfs_under_out_is_found_before_the_work(tmpfs, capsys, no_runs):
    full = tmpfs("size=64k")
    _fill(full)
    status, err = cli(["sensitivity", "--out", str(full / "sens")], capsys)
    assert status == 2 and "--out" in err and "full disk" in err


def test_an_unwritable_out_is_found_before_the_work(tmpfs, capsys, no_runs):
    ro = tmpfs("ro,size=64k")
    status, err = cli(["sensitivity", "--out", str(ro / "sens")], capsys)
    assert status == 2 and "--out" in err and "not writable" in err


def test_a_failed_write_names_the_file(tmp_path, tmpfs):
    target = tmp_path / "traj.npz"
    with pytest.raises(OSError) as info, atomic_file(target) as tmp:
        raise OSError(errno.ENOSPC, "No space left on device")   # a write that failed
    assert info.value.filename == str(target) and not list(tmp_path.iterdir())
    full = tmpfs("size=64k")
    with pytest.raises(OSError) as info, atomic_file(full / "big.npz") as tmp:
        tmp.write_bytes(b"x" * 1024 * 1024)
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(full / "big.npz")


def test_a_damaged_map_is_named(tmp_path, monkeypatch, capsys, no_runs):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "map.nc").write_bytes(b"CDF\x01" + b"\0" * 100)    # cut short
    status, err = cli(["map", "--sweep", "clearance=1e-5:1e-4:3", "--out", "m"], capsys)
    assert status == 2 and "'map.nc'" in err and "damaged" in err


@pytest.mark.skipif(not hasattr(signal, "SIGTERM") or os.name != "posix", reason="posix")
def test_sigterm_during_report_leaves_no_partial_folder(tmp_path):
    proc = subprocess.Popen([sys.executable, "-m", "mbs_clearance.cli", "report", "--quick",
                             "--out", "r"], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not list(tmp_path.glob(".r.partial-*")):
        assert proc.poll() is None, proc.stderr.read()
        assert time.monotonic() < deadline, "the report never started its folder"
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == []
