"""The contact and friction laws of the clearance joint, one module per law
(`laws.contact.<name>`, `laws.friction.<name>`), each declaring its name, parameters (unit,
default, allowed range, source) and its formula once; `laws.registry` lists them (the
order gives the kernels' integer ids) and `laws._dispatch`, generated from the registry by
`python -m mbs_clearance.laws.codegen`, compiles them and their partial derivatives."""

from .registry import (
    CONTACT,
    CONTACT_MODELS,
    FRICTION,
    FRICTION_LAWS,
    FRICTION_PARAMETER_SPECS,
    FRICTION_SLOTS,
    contact_law,
    friction_law,
)

__all__ = ["CONTACT", "FRICTION", "CONTACT_MODELS", "FRICTION_LAWS", "FRICTION_SLOTS",
           "FRICTION_PARAMETER_SPECS",
           "contact_law", "friction_law"]
