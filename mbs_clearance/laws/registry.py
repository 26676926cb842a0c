"""The registry of the contact and friction laws: which law modules exist, in the order that
gives their integer ids inside the compiled kernels (`_dispatch`, generated from this list
by `python -m mbs_clearance.laws.codegen`). Adding a law: its module, one line here, the
regenerated dispatch, and its entry in the law tests (parametrised over this registry)."""

from __future__ import annotations

from .base import ContactLaw, FrictionLaw, Parameter
from .contact import flores, hu_guo, hunt_crossley, lankarani_nikravesh
from .friction import ambrosio, coulomb, none, stribeck

__all__ = ["CONTACT", "FRICTION", "CONTACT_MODELS", "FRICTION_LAWS", "FRICTION_SLOTS",
           "FRICTION_PARAMETER_SPECS", "contact_law", "friction_law"]

#: the contact laws; the position is the kernel id
CONTACT: tuple[ContactLaw, ...] = (
    lankarani_nikravesh.LAW,
    hunt_crossley.LAW,
    flores.LAW,
    hu_guo.LAW,
)

#: the friction laws; the position is the kernel id ("none" first: id 0 is frictionless)
FRICTION: tuple[FrictionLaw, ...] = (
    none.LAW,
    coulomb.LAW,
    ambrosio.LAW,
    stribeck.LAW,
)

#: the description fields the kernels pass to every friction law, in order (each law reads
#: the ones in its `arguments`)
FRICTION_SLOTS: tuple[str, ...] = ("friction_coefficient", "friction_v0", "friction_v1",
                                   "friction_static_coefficient",
                                   "friction_stribeck_velocity")

#: the declared parameters of the friction slots (the first law's declaration of each)
FRICTION_PARAMETER_SPECS: tuple[Parameter, ...] = tuple(
    {p.name: p for law in reversed(FRICTION) for p in law.parameters}[f] for f in FRICTION_SLOTS)

#: contact law name -> integer id used inside compiled kernels
CONTACT_MODELS: dict[str, int] = {law.name: i for i, law in enumerate(CONTACT)}

#: friction law name -> integer id used inside compiled kernels
FRICTION_LAWS: dict[str, int] = {law.name: i for i, law in enumerate(FRICTION)}


def contact_law(name: str) -> ContactLaw:
    """The contact law called `name`."""
    return CONTACT[CONTACT_MODELS[name]]


def friction_law(name: str) -> FrictionLaw:
    """The friction law called `name`."""
    return FRICTION[FRICTION_LAWS[name]]
