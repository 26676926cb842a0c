"""Friction laws, one module each (see `mbs_clearance.laws`)."""
