"""Free (undriven) linkages: the description's round trip and every refusal, before any
model is generated or compiled (the runs against references are in
tests/integration/test_free_linkage.py)."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from mbs_clearance import Initial, simulate
from mbs_clearance.model import cases
from mbs_clearance.model.linkage import Linkage
from mbs_clearance.solve import linkage_model as lm


def free_case(**initial) -> Linkage:
    """The paper's slider-crank without its drive, from `initial` (Initial's fields)."""
    return cases.paper_slider_crank().replace(name="free_case", drive=None,
                                              initial=Initial(**initial))


def test_free_description_round_trips_and_refuses_bad_starts(tmp_path):
    lk = free_case(coordinates={"crank.angle": 0.3}, rates={"crank.angle": 10.0})
    assert lk.coordinates() == ("crank.angle", "coupler.angle", "slider_guide.s")
    assert "drive.speed" not in lk.parameter_names()
    assert lk.structure()["drive"] is None
    assert lk.rate_scale == 10.0 and lk.time_scale == pytest.approx(2 * math.pi / 10.0)
    # the closure is solved with the crank held at its given angle: journal centred there
    q = lk.assemble()
    assert max(abs(v) for v in lk.gaps(q)) < 1e-9
    data = lk.to_dict()
    assert "drive" not in data and data["initial"]["rates"] == {"crank.angle": 10.0}
    assert Linkage.from_dict(json.loads(json.dumps(data))) == lk
    path = tmp_path / "free.json"
    path.write_text(json.dumps(data))
    assert Linkage.from_file(path) == lk
    assert free_case().start == Initial()          # a free linkage without initial: at rest
    driven = cases.paper_slider_crank()
    # back to driven: an empty start is dropped, a driven linkage has none
    assert lk.replace(drive=driven.drive, initial=Initial()).initial is None
    bad = [
        (lambda: Initial(rates={"crank.angle": math.inf}), r"initial rates\['crank.angle'\]"),
        (lambda: Initial(coordinates=[1.0]), "initial coordinates must be a mapping"),
        (lambda: free_case(rates={"crank.omega": 1.0}), "unknown coordinate 'crank.omega'"),
        (lambda: dataclasses.replace(driven, initial=Initial(rates={"coupler.angle": 1.0})),
         "initial is for a free"),
        (lambda: free_case().period, "free .* duration"),
        (lambda: Linkage.from_dict({**data, "initial": {"speeds": {}}}),
         "unknown initial key 'speeds'"),
        (lambda: Linkage.from_dict({k: v for k, v in data.items() if k != "initial"}),
         "lacks the key 'drive'"),
    ]
    for make, message in bad:
        with pytest.raises(ValueError, match=message):
            make()


def test_free_runs_take_a_duration_and_driven_runs_revolutions():
    # every refusal comes before a model is loaded (no kernel compiles here)
    lk = free_case()
    driven = cases.paper_slider_crank()
    np.testing.assert_allclose(lm.time_edges(0.25, 0.1), [0.0, 0.1, 0.2, 0.25])
    np.testing.assert_array_equal(lm.time_edges(0.2), [0.0, 0.2])
    bad = [
        (lambda: lm.run(lk, 4), "free .* duration= .* instead of revolutions=4"),
        (lambda: lm.run(lk), "give its run's duration"),
        (lambda: lm.run(lk, duration=-1.0), "duration must be a finite number > 0"),
        (lambda: lm.run(lk, duration=0.1, window=0.2), "window must be"),
        (lambda: lm.run(driven, duration=0.1), "driven: its runs cover revolutions="),
        (lambda: lm.run(driven, window=0.1), "duration= and window= are for a free"),
        (lambda: simulate(lk, 4), "instead of revolutions=4"),
        (lambda: simulate(lk, backend="exudyn", revolutions=2), "instead of revolutions=2"),
        (lambda: simulate(lk, backend="exudyn"), "give its run's duration"),
        (lambda: simulate(cases.paper_slider_crank().replace(name="x"), duration=1.0,
                          rtol=1e-7), "driven"),
    ]
    for make, message in bad:
        with pytest.raises(ValueError, match=message):
            make()
