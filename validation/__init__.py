"""Validation of mbs-clearance: cross-model comparison, stress sweep, benchmarks, report."""
