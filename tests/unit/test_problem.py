"""The one prepared run (`linkage_model.prepare` -> `Problem`) as the DDM, the finite
differences and the flows take it: the span decides free or driven, and a run from a
prepared problem is the run the convenience entry points make."""

import numpy as np
import pytest

from mbs_clearance.model import cases
from mbs_clearance.model.linkage import Initial
from mbs_clearance.solve import linkage_ddm
from mbs_clearance.solve.flows import Flow, TangentFlow, prepare_flow
from mbs_clearance.solve.linkage_model import prepare, solve


def _free():
    return cases.paper_slider_crank().replace(name="free_case", drive=None,
                                              initial=Initial(rates={"crank.angle": 100.0}))


def test_a_run_that_ends_at_its_last_output_time_lands_on_the_same_values():
    """``whole=False`` lands on 0 and t_eval only and ends at the last of them, its windows
    the revolutions; its values at t_eval equal a run that also lands on the revolution
    edges (another step sequence) within the integration's error."""
    linkage = cases.paper_slider_crank()
    t_eval = np.linspace(0.1, 1.3, 9) * linkage.period
    short = prepare(linkage, 2, t_eval=t_eval, whole=False, rtol=1e-10)
    whole = prepare(linkage, 2, t_eval=t_eval, rtol=1e-10)
    np.testing.assert_array_equal(short.span.edges, np.r_[0.0, t_eval])
    np.testing.assert_array_equal(short.span.windows, np.arange(3) * linkage.period)
    assert whole.span.edges[-1] == 2 * linkage.period
    a, b = solve(short), solve(whole)
    np.testing.assert_array_equal(a.ts, t_eval)
    np.testing.assert_allclose(a.ys[:, :4], b.ys[:, :4], rtol=1e-6, atol=1e-9)


def test_the_span_says_free_or_driven():
    """A sensitivity problem's span: a driven linkage's revolutions, a free linkage's time
    windows (no revolutions) from duration and window; the directions of the description's
    parameters themselves, with their values."""
    sp = linkage_ddm.prepare_sensitivity(_free(), ("coupler.mass",), duration=0.01,
                                         window=0.004)
    assert sp.problem.span.revolutions is None and not sp.fixed_start
    np.testing.assert_allclose(sp.problem.span.windows, [0.0, 0.004, 0.008, 0.01])
    driven = cases.paper_slider_crank()
    sp = linkage_ddm.prepare_sensitivity(driven, ("coupler.mass",), 3)
    assert sp.problem.span.revolutions == 3
    assert sp.directions.directions == [{"coupler.mass": 1.0}]
    assert sp.directions.reference[0] == driven.parameter_value("coupler.mass")
    with pytest.raises(ValueError, match="free .*duration="):
        linkage_ddm.prepare_sensitivity(_free(), ("coupler.mass",), 1)


def test_a_flow_from_its_prepared_problem_is_the_flow_of_the_mechanism():
    """A flow built from `prepare_flow`'s Problem advances exactly as the flow built from the
    mechanism with the same settings (plain and tangent); settings beside a Problem are
    refused."""
    linkage = cases.paper_slider_crank()
    problem = prepare_flow(linkage, rtol=1e-9)
    a, b = Flow(problem), Flow(linkage, rtol=1e-9)
    assert a.advance(linkage.period) == b.advance(linkage.period)
    np.testing.assert_array_equal(a.y, b.y)
    ta = TangentFlow(prepare_flow(linkage, rtol=1e-9, default_method="dop853"))
    tb = TangentFlow(linkage, rtol=1e-9)
    ta.advance(linkage.period)
    tb.advance(linkage.period)
    assert ta.renormalise() == tb.renormalise()
    with pytest.raises(ValueError, match="prepared Problem carries its settings"):
        Flow(problem, rtol=1e-8)
    free = Flow(_free(), free=True)
    assert free.omega is None and free.problem.span.revolutions is None


def test_one_span_preparation_for_every_backend():
    """`prepare_span`: a driven linkage's windows are its revolutions (edges k T, T = 2 pi /
    drive speed), a free linkage's the time windows of its duration, without revolutions;
    the reduced model, Exudyn and the ideal-joint backend refuse a bad span with its one
    message, before any run."""
    from mbs_clearance.backends import exudyn_linkage as xl
    from mbs_clearance.backends.ideal_linkage import constrained_run
    from mbs_clearance.solve.linkage_model import prepare_span

    driven = cases.paper_slider_crank()
    span = prepare_span(driven, 3)
    np.testing.assert_allclose(span.edges, np.arange(4) * 2 * np.pi / driven.drive.speed,
                               rtol=1e-15)
    assert span.revolutions == 3 and span.windows is span.edges
    free = prepare_span(_free(), duration=0.01, window=0.004)
    np.testing.assert_allclose(free.edges, [0.0, 0.004, 0.008, 0.01], rtol=1e-15)
    assert free.revolutions is None and free.duration == 0.01
    runs = {"reduced": prepare, "exudyn": xl.simulate_exudyn_linkage,
            "exudyn peak": xl.peak_exudyn_linkage, "ideal": constrained_run}
    for linkage, kwargs in ((_free(), {}), (_free(), {"window": 0.01}),
                            (driven, {"duration": 0.01}), (driven, {"edges": [0.0, -1.0]})):
        with pytest.raises(ValueError) as expected:
            prepare_span(linkage, **kwargs)
        for name, run in runs.items():
            if "edges" in kwargs and name != "reduced":     # the reduced model's option
                continue
            with pytest.raises(ValueError) as got:
                run(linkage, **kwargs)
            assert str(got.value) == str(expected.value), name
    for run in runs.values():
        with pytest.raises(ValueError, match=r"free \(drive=None\).*instead of revolution"):
            run(_free(), 2, duration=0.01)
