"""Validation of mbs-clearance: cross-model comparison, stress sweep, benchmarks, report."""

from mbs_clearance._cache import register_package

# validation.stress's kernel compiles in code of mbs_clearance (the generated model's rhs,
# generate/runtime.gap_state, rk_step): its cache key covers both packages' sources
# (mbs_clearance/_cache.py)
try:
    register_package(__name__, depends_on=("mbs_clearance",))
except KeyError:
    # mbs_clearance imported from a checkout older than the cache registry (an A/B of
    # benchmarks/integrator_ab.py against it): numba's own cache locators apply
    pass
