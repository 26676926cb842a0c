"""Messages of the library: through the logger "mbs_clearance", where results are coarse."""

import logging

import pytest

from mbs_clearance import SliderCrank
from mbs_clearance.analysis.sensitivity import sensitivities


class _Stop(Exception):
    pass


def _no_run(*args, **kwargs):
    raise _Stop


@pytest.mark.parametrize("step,coarse", [(None, True), (2e-6, True), (1e-6, True),
                                         (5e-7, False)])
def test_exudyn_finite_differences_say_when_coarse(step, coarse, caplog, monkeypatch):
    """FD through Exudyn at its default step (or any step above 7.5e-7 s) warns, once and
    before any run, that it is 15-19 % RMS off DDM and names the step that gives ~1 %
    (docs/sensitivity.md, measured); at 5e-7 s it says nothing."""
    import importlib

    sim = importlib.import_module("mbs_clearance.solve.simulate")   # the module, not the function

    monkeypatch.setattr(sim, "simulate", _no_run)      # stop at the first run
    options = {} if step is None else {"step_size": step}
    with caplog.at_level(logging.INFO, logger="mbs_clearance"), pytest.raises(_Stop):
        sensitivities(SliderCrank(), ["crank_length"], 1, method="fd", backend="exudyn",
                      **options)
    records = [r for r in caplog.records if r.name == "mbs_clearance"]
    if not coarse:
        assert not records
        return
    (record,) = records
    assert record.levelno == logging.WARNING
    text = record.getMessage()
    assert "15-19 % RMS off the DDM" in text and "step_size=5e-7 gives about 1 %" in text
    assert f"at step {step or 2e-6:g} s" in text


@pytest.mark.skipif(not hasattr(__import__("os"), "openpty"), reason="needs a pseudo terminal")
def test_compile_message_shows_on_a_terminal(tmp_path):
    """A first run on a terminal says what it derives and compiles: the CLI in a real
    process whose stdin/stdout/stderr are a pseudo terminal, with empty caches of the
    compiled core (MBS_CLEARANCE_CACHE_DIR is tried first, `core.build`), prints
    "deriving the model of linkage 'four_bar' in C ..." and "compiling LIBRARY (first use
    only ...)" before it builds. The process is ended at that line: no compilation is
    waited for."""
    import os
    import re
    import select
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, MBS_CLEARANCE_CACHE_DIR=str(tmp_path / "core-cache"),
               XDG_CACHE_HOME=str(tmp_path / "xdg"), COLUMNS="100")
    env.pop("MBS_CLEARANCE_DEBUG", None)
    master, slave = os.openpty()
    # the four-bar with friction in its joint: a structure whose source is not shipped
    import json

    from mbs_clearance.model.cases import four_bar

    data = four_bar().to_dict()
    data["clearance_joints"][0].update(friction_law="coulomb", friction_coefficient=0.05)
    description = tmp_path / "four_bar_friction.json"
    description.write_text(json.dumps(data))
    proc = subprocess.Popen([sys.executable, "-m", "mbs_clearance.cli", "simulate",
                             "--description", str(description), "--revolutions", "1"],
                            stdin=slave, stdout=slave, stderr=slave, cwd=root, env=env,
                            start_new_session=True)
    os.close(slave)
    text = b""
    try:
        deadline = time.monotonic() + 180
        while b"compiling " not in text and time.monotonic() < deadline:
            ready, _, _ = select.select([master], [], [], 1.0)
            if ready:
                try:
                    chunk = os.read(master, 4096)
                except OSError:         # the terminal closed: the process ended
                    break
                if not chunk:
                    break
                text += chunk
            elif proc.poll() is not None:
                break
        # let the rest of the line arrive
        time.sleep(0.2)
        while select.select([master], [], [], 0.1)[0]:
            try:
                chunk = os.read(master, 4096)
            except OSError:
                break
            if not chunk:
                break
            text += chunk
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        os.close(master)
    shown = text.decode(errors="replace").replace("\r", "")
    assert re.search(r"^mbs-clearance simulate: compiling [\w-]+ \(first use only"
                     r"(, about \d+ s)?\)$", shown, re.M), shown
    assert re.search(r"^mbs-clearance simulate: deriving the model of linkage 'four_bar' in "
                     r"C \(first use of its structure only\)$", shown, re.M), shown
    # the note that work starts comes first, so the user sees what is being compiled for
    assert shown.index("simulating 'four_bar'") < shown.index("compiling ")
