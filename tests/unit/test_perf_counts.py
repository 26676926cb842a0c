"""The plain run's cost pinned by counts (docs/performance.md, "Where the time goes")."""

from __future__ import annotations

import pytest

from mbs_clearance import SliderCrank, simulate
from mbs_clearance.solve import reduced


def test_paper_case_cost_counts():
    """The paper case's default run (4 revolutions, rtol 1e-7): its rev-4 peak, function
    evaluations, steps, events and refined steps; a change of any count changes the run's
    cost (or its result) and must be explained. The event search's margin is 0.001 c
    (`linkage_model.event_margin`); with 0.05 c the approach step limit near the onsets and
    separations differs: 8291.958246907485 N, 59911, 9711 + 255 (both within 9.3e-7 of the
    rtol 1e-12 run's peak, the difference 2.3e-9). The model is specialised on its
    zero-valued geometric parameters (the journal's gap 3 + 2 + 3 + 2 terms instead of
    6 + 6 + 5 + 5): the same counts as the general model, the peak 8291.958273534865 N
    against 8291.95826563021 N (round-off of the shorter sums, 9.5e-10; the run's error
    against rtol 1e-12 is 9.3e-7)."""
    traj = simulate(SliderCrank(), 4, rtol=reduced.DEFAULT_RTOL)
    s = traj.stats
    assert (s["nfev"], s["naccept"], s["nreject"], s["nevent"], s["nrefine"]) == (
        59959, 9712, 261, 5, 23)
    assert traj.peaks[-1] == pytest.approx(8291.958273534865, rel=1e-12)
