"""Validation of mbs-clearance: cross-model comparison, stress sweep, benchmarks, report."""

from mbs_clearance._cache import register_package

# validation.stress's kernel compiles in code of mbs_clearance (the generated model's rhs,
# generate/runtime.gap_state, rk_step): its cache key covers both packages' sources
# (mbs_clearance/_cache.py)
register_package(__name__, depends_on=("mbs_clearance",))
