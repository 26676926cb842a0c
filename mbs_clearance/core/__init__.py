"""The compiled core: C sources (integrator, events, peaks), their build and binding, and the
Python side of the seam between a model and the core (`mbs_core.h`)."""
