"""Property tests over valid parameter ranges: finite outputs, no contact missed."""

import math
import os
import warnings

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mbs_clearance import AccuracyWarning, SliderCrank, simulate
from mbs_clearance.laws.forces import CONTACT_MODELS

mechanisms = st.builds(
    lambda c, rpm, e, l2, l3, m3, m4, th0, model, g: SliderCrank(
        journal_radius=0.01 - c, crank_speed=rpm * 2 * math.pi / 60, restitution=e,
        crank_length=l2, coupler_length=l3, coupler_mass=m3, slider_mass=m4,
        initial_crank_angle=th0, contact_model=model, gravity=g),
    c=st.floats(1e-6, 1e-3),
    rpm=st.floats(300, 8000),
    e=st.floats(0.3, 1.0),
    l2=st.floats(0.04, 0.06),
    l3=st.floats(0.10, 0.14),
    m3=st.floats(0.1, 0.4),
    m4=st.floats(0.07, 0.3),
    th0=st.floats(0, 2 * math.pi),
    model=st.sampled_from(sorted(CONTACT_MODELS)),
    g=st.sampled_from([0.0, 9.81]),
)


# CI runs a fixed set of examples (reproducible builds); elsewhere hypothesis explores
@settings(max_examples=int(os.environ.get("MBS_HYPOTHESIS_EXAMPLES", 25)), deadline=None,
          derandomize=bool(os.environ.get("CI")),
          suppress_health_check=[HealthCheck.too_slow])
@given(mech=mechanisms)
def test_outputs_finite_and_no_penetration_in_free_flight(mech):
    # a run may warn that its peaks may miss the stated accuracy (e.g. a grazing onset,
    # found by hypothesis at 0.09 mm, 2949 rpm, e = 0.375): that is the documented warning,
    # not a failure of the properties checked here
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        traj = simulate(mech, 1)
    for name in ("t", "base_force", "crank_moment", "contact_force", "penetration",
                 "eccentricity", "slider_position", "slider_velocity", "slider_acceleration",
                 "crank_work"):
        assert np.all(np.isfinite(getattr(traj, name))), name
    free = traj.contact_phase == 0
    # a free-flight sample inside the wall would be a missed contact. Events land within
    # 1e-12 c of the wall, or within the round-off of delta (a difference of coordinates of
    # size L2 + L3, ~1e-16 m), whichever is larger: allow 1e-9 c plus 1e-14 (L2 + L3)
    tol = 1e-9 * mech.clearance + 1e-14 * (mech.crank_length + mech.coupler_length)
    assert np.all(traj.penetration[free] <= tol)
    assert np.all(traj.contact_force[free] == 0.0)
    assert np.all(traj.contact_force >= 0.0)
    # in contact the journal never leaves the wall without a separation event
    assert np.all(traj.penetration[~free] >= -tol)
    assert np.isfinite(traj.max_base_force(1))
