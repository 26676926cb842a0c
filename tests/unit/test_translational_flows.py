"""The tangent flow, the monodromy matrix and periodic orbits through the corners of a
translational clearance joint, and the finite-time Lyapunov exponent of a free linkage.
References: central differences of the one-revolution map (plain runs), an independent
plain `simulate` run from the orbit's state, and the separation of two nearby plain runs."""

import sys
from pathlib import Path

import pytest

from mbs_clearance.model import cases

sys.path.insert(0, str(Path(__file__).parent))
from test_translational import guided  # noqa: E402

# ---------------------------------------------------------------- refusals (fast)

def test_free_linkage_refusals_before_any_work():
    """A free linkage has no drive period: the periodic orbits refuse it by that reason;
    its exponent takes duration= (a whole number of window=), not revolutions; a driven
    linkage's exponent refuses duration= and window=. All before any model is loaded."""
    from mbs_clearance.analysis.lyapunov import lyapunov_exponent
    from mbs_clearance.analysis.periodic import continue_orbits, periodic_orbit

    lk = cases.flores_translational_slider_crank()
    with pytest.raises(ValueError, match="is free .*no drive period"):
        periodic_orbit(lk)
    with pytest.raises(ValueError, match="is free .*no drive period"):
        continue_orbits(lk, "guide.clearance", 1e-3, 2e-3)
    with pytest.raises(ValueError, match="is free .*give the exponent's duration="):
        lyapunov_exponent(lk)
    with pytest.raises(ValueError, match="no drive revolutions; give duration="):
        lyapunov_exponent(lk, revolutions=10, duration=0.01)
    with pytest.raises(ValueError, match=r"duration \(0.01 s\) must be a whole number of "
                                         r"windows \(window 0.003 s\)"):
        lyapunov_exponent(lk, duration=0.01, window=0.003)
    with pytest.raises(ValueError, match="window must be a finite number"):
        lyapunov_exponent(lk, duration=0.01, window=0.02)
    with pytest.raises(ValueError, match=r"transient \(windows not averaged\)"):
        lyapunov_exponent(lk, duration=0.01, window=0.005, transient=2)
    _, driven = guided()
    with pytest.raises(ValueError, match="is driven: .*duration= and window= are for a free"):
        lyapunov_exponent(driven, duration=0.01)
