"""Messages of the library: through the logger "mbs_clearance", where results are coarse."""

import logging

import pytest

from mbs_clearance import SliderCrank
from mbs_clearance.sensitivity import sensitivities


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

    sim = importlib.import_module("mbs_clearance.simulate")   # the module, not the function

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
