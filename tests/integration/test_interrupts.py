"""Real processes interrupted, racing and running out of disk: Ctrl-C (SIGINT) and SIGTERM
during `map`, `optimize` and `tolerance` on 2 workers leave no process behind and either a
resumable map or no result at all (never a half-written result that looks complete); a
second run writing into the same folder is refused; a full disk ends in one line and leaves
no corrupt output."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mbs_clearance._io import MANIFEST
from mbs_clearance.studies.sweep import load_map

psutil = pytest.importorskip("psutil")

#: a map that runs for tens of seconds on 2 workers (about 0.3 s per point)
MAP = ["map", "--sweep", "clearance=1e-5:5e-4:log:40", "--revolutions", "120", "--keep", "5",
       "--max-period", "2", "--write-interval", "0", "--workers", "2"]
#: a GA and a tolerance study that run for tens of seconds on 2 workers
OPTIMIZE = ["optimize", "--population", "40", "--generations", "200", "--saturation", "0",
            "--workers", "2", "--no-refine"]
TOLERANCE = ["tolerance", "inputs.json", "--sobol", "256", "--workers", "2"]
INPUTS = '{"crank_length": {"band": [0.05, 5e-4]}, "coupler_length": {"band": [0.12, 5e-4]}}'


def _start(argv, cwd: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    return subprocess.Popen([sys.executable, "-m", "mbs_clearance.cli", *argv], cwd=cwd,
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)


def _session_members(sid: int) -> list[int]:
    out = []
    for p in psutil.process_iter(["pid"]):
        try:
            if os.getsid(p.info["pid"]) == sid:
                out.append(p.info["pid"])
        except (ProcessLookupError, PermissionError):
            continue
    return out


def _wait_until_working(proc, ready, timeout=600.0) -> None:
    """Wait until `ready()` (the run is evaluating designs), or fail."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert proc.poll() is None, f"the run ended before the signal: {proc.stderr.read()}"
        if ready():
            return
        time.sleep(0.05)
    pytest.fail("the run did not start working in time")


def _busy(proc) -> bool:
    """True once the process has used 2 s of CPU after its imports (it is evaluating)."""
    try:
        cpu = psutil.Process(proc.pid).cpu_times()
    except psutil.NoSuchProcess:
        return False
    return cpu.user + cpu.system > 2.0 + _busy.import_cpu


#: CPU seconds that starting the command line takes (measured once per session)
_busy.import_cpu = 0.0


@pytest.fixture(scope="module", autouse=True)
def _import_cpu():
    t = time.process_time()
    proc = subprocess.run([sys.executable, "-c", "import time, mbs_clearance.cli, "
                           "mbs_clearance.studies.optimize, mbs_clearance.studies.tolerance, "
                           "mbs_clearance.studies.sweep;"
                           " print(time.process_time())"], capture_output=True, text=True)
    _busy.import_cpu = float(proc.stdout.strip() or 0.0) + (time.process_time() - t)


def _interrupt(proc, sig) -> tuple[int, str]:
    proc.send_signal(sig)
    try:
        _, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail(f"the run did not stop within 120 s of {sig!r}")
    return proc.returncode, err


def _no_leftovers(tmp_path: Path, sid: int, name: str) -> None:
    time.sleep(0.5)
    assert _session_members(sid) == [], "a process of the run is left behind"
    hidden = [p.name for p in tmp_path.iterdir() if p.name.startswith(f".{name}.")]
    assert hidden == [], hidden


@pytest.mark.slow
@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_map_interrupted_leaves_a_resumable_map(tmp_path, sig, code):
    out = tmp_path / "map"
    proc = _start([*MAP, "--no-progress", "--out", str(out)], tmp_path)

    def two_points():
        try:
            return int(load_map(out / "map.nc")["done"].sum()) >= 2
        except ValueError:
            return False

    _wait_until_working(proc, two_points)
    status, err = _interrupt(proc, sig)
    assert status == code, err
    assert "Traceback" not in err and "internal error" not in err
    _no_leftovers(tmp_path, proc.pid, "map")
    # the result: a complete map file with the points done so far, and no figures or
    # manifest that would make the folder look finished
    part = load_map(out / "map.nc")
    assert 2 <= int(part["done"].sum()) < 40
    assert sorted(p.name for p in out.iterdir()) == ["map.nc"]
    # resumed, it skips the points done and finishes the folder
    proc = _start([*MAP, "--no-progress", "--out", str(out)], tmp_path)
    _, err = proc.communicate(timeout=900)
    assert proc.returncode == 0, err
    assert f"{int(part['done'].sum())} resumed" in err
    assert {"map.nc", "bifurcation.png", MANIFEST} <= {p.name for p in out.iterdir()}


@pytest.mark.slow
@pytest.mark.parametrize("command", ["optimize", "tolerance"])
@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupted_study_leaves_no_result(tmp_path, command, sig, code):
    (tmp_path / "inputs.json").write_text(INPUTS)
    argv = {"optimize": OPTIMIZE, "tolerance": TOLERANCE}[command]
    proc = _start([*argv, "--no-progress"], tmp_path)
    _wait_until_working(proc, lambda: _busy(proc))
    status, err = _interrupt(proc, sig)
    assert status == code, err
    assert err.strip().endswith("interrupted") or status == 143, err
    assert "Traceback" not in err
    _no_leftovers(tmp_path, proc.pid, command)
    assert not (tmp_path / command).exists()           # clearly absent
    assert sorted(p.name for p in tmp_path.iterdir()) == ["inputs.json"]


@pytest.mark.slow
def test_two_runs_into_the_same_map_folder(tmp_path):
    out = tmp_path / "map"
    first = _start([*MAP, "--no-progress", "--out", str(out)], tmp_path)
    _wait_until_working(first, lambda: (out / "map.nc").exists())
    second = _start([*MAP, "--no-progress", "--out", str(out)], tmp_path)
    _, err = second.communicate(timeout=300)
    assert second.returncode == 2, err
    assert "is in use by another mbs-clearance run" in err and err.count("\n") == 1
    _interrupt(first, signal.SIGINT)
    assert int(load_map(out / "map.nc")["done"].sum()) >= 0     # still a complete file


@pytest.mark.slow
def test_two_tolerance_runs_into_the_same_folder_end_as_one_complete_run(tmp_path):
    """Folders built aside and renamed into place: whichever run ends last, the folder is
    one complete run (its manifest's files, unchanged)."""
    from mbs_clearance._io import verify_run_folder

    (tmp_path / "inputs.json").write_text(INPUTS)
    argv = ["tolerance", "inputs.json", "--sobol", "16", "--workers", "1", "--no-progress"]
    procs = [_start(argv + ["--seed", str(k)], tmp_path) for k in (1, 2)]
    for p in procs:
        _, err = p.communicate(timeout=600)
        assert p.returncode == 0, err
    manifest = verify_run_folder(tmp_path / "tolerance")
    assert set(manifest["files"]) == {"result.json", "summary.txt"}
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


@pytest.fixture
def tiny_disk(tmpfs):
    """A 96 KiB tmpfs (needs root and mount; skipped elsewhere)."""
    return tmpfs("size=96k")


@pytest.mark.slow
@pytest.mark.parametrize("command", ["map", "tolerance"])
def test_full_disk_one_line_and_no_corrupt_output(tiny_disk, tmp_path, command):
    (tiny_disk / "inputs.json").write_text(INPUTS)
    with open(tiny_disk / "filler", "wb", buffering=0) as fh:   # the disk full
        try:
            while True:
                fh.write(b"x" * 1024)
        except OSError as exc:
            assert exc.errno == errno.ENOSPC
    argv = {"map": ["map", "--sweep", "clearance=1e-5:5e-4:log:3", "--revolutions", "12",
                    "--keep", "5", "--max-period", "2", "--workers", "1"],
            "tolerance": ["tolerance", "inputs.json", "--sobol", "16", "--workers", "1"]}
    proc = _start([*argv[command], "--no-progress"], tiny_disk)
    _, err = proc.communicate(timeout=600)
    # a disk already full is refused before any computation (status 2, naming --out and
    # the free space); one that fills during the run fails with the OS's message (status 1)
    if proc.returncode == 2:
        assert err.count("\n") == 1 and "--out" in err and "(full disk)" in err, err
    else:
        assert proc.returncode == 1, err
        assert err.count("\n") == 1 and "No space left on device: " in err, err
        assert command in err.split("No space left on device: ")[1], err
    left = sorted(p.name for p in tiny_disk.iterdir())
    if command == "map" and (tiny_disk / "map").exists():
        # a map that could not be finished: at most its last complete map.nc, resumable
        assert sorted(p.name for p in (tiny_disk / "map").iterdir()) in ([], ["map.nc"])
        if (tiny_disk / "map" / "map.nc").exists():
            load_map(tiny_disk / "map" / "map.nc")
        left.remove("map")
    assert left == ["filler", "inputs.json"], left
    assert not any(p.name == MANIFEST for p in tiny_disk.rglob("*"))
