"""A regime map killed with SIGKILL midway (no chance to clean up) and resumed gives the same
dataset as an uninterrupted run: the file on disk is always a complete dataset (written
whole and renamed) and every point is a deterministic run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from mbs_clearance import SliderCrank, regime_map
from mbs_clearance.studies.sweep import load_map as _load

SWEEP = "clearance=1e-5:5e-4:log:6"
#: 120 revolutions per point: long enough (about 0.3 s on a 2-core machine) that the polling
#: below sees the file between two points; with 12, a fast machine finished all six points
#: between two polls and the kill came too late
REVOLUTIONS = 120
ARGS = dict(revolutions=REVOLUTIONS, keep=5, max_period=2)


@pytest.mark.slow
def test_sigkill_midway_then_resume_equals_uninterrupted(tmp_path):
    out = tmp_path / "killed"
    cmd = [sys.executable, "-m", "mbs_clearance.cli", "map", "--sweep", SWEEP,
           "--revolutions", str(REVOLUTIONS), "--keep", "5", "--max-period", "2", "--workers", "1",
           "--no-progress", "--write-interval", "0", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            cwd=os.getcwd())
    path = out / "map.nc"
    deadline = time.monotonic() + 600
    done = 0
    while time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.02)
        if path.exists():
            try:
                done = int(_load(path)["done"].sum())
            except (OSError, ValueError):
                continue        # never a partial file: only while renamed over
            if done >= 2:
                break
    assert proc.poll() is None, "the run ended before it could be killed"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    part = _load(path)
    assert 2 <= int(part["done"].sum()) < 6
    resumed = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    whole = regime_map(SliderCrank(), SWEEP, scheduler="serial", **ARGS).dataset
    final = _load(path)
    for name in whole.data_vars:
        np.testing.assert_array_equal(final[name].values, whole[name].values, err_msg=name)
