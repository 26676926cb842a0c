"""What an element module brings: the pieces of one joint kind that the generator
(`generate.derive`, `writer`, `cwriter`, `jacobians`, `cjacobians`, `energy`), the reduced
model (`solve.linkage_model`, `solve.linkage_ddm`), the Exudyn backend
(`backends.exudyn_linkage`) and the ideal-joint backend (`backends.ideal_linkage`) ask of
every registered element that brings their piece (`Element.pieces`), in the registry's
order.

An element owns the joints of one field of the description (`Element.attribute` of a
`Linkage`, e.g. ``clearance_joints``, ``translational_joints``) and their *contacts* (the
events of the compiled model, each with its own mode and impact-velocity memory), which
follow the earlier elements' in every layout. Every hook takes all the element's joints of
one linkage at once, so that its entries stay together in the parameter vector, the rows
and the outputs; a linkage without joints of the kind gets empty contributions and the
model is printed as if the element did not exist.
"""

from __future__ import annotations

from types import SimpleNamespace

from ..laws.registry import FRICTION_SLOTS

__all__ = ["Element", "PIECES", "CONTACT_FIELDS", "friction_arguments"]

#: per contact, the entries of p read by the contact law
CONTACT_FIELDS = ("clearance", "stiffness", "restitution", "contact_model",
                  "impact_velocity_floor")


def friction_arguments(items: list[str]) -> str:
    """The friction law's slots as the items of a tuple in a generated line (a one-slot
    tuple keeps its comma)."""
    return ", ".join(items) + ("," if len(FRICTION_SLOTS) == 1 else "")


#: the hooks every element defines, by the layer that calls them (the registry test checks
#: each registered element; `Element.joints` comes from the base, read from `attribute`)
PIECES: dict[str, tuple[str, ...]] = {
    "description": ("contact_names",),
    "gap function and loads": ("parameter_names", "memory_names", "base_angles",
                               "add_loads", "ground_reaction", "finish", "specialise"),
    "C printer": ("plan", "out_columns", "friction_contacts", "profiled_stages",
                  "penetration_lines", "closure"),
    "Jacobian rows and tangent terms": ("jacobian_rows", "jacobian_lines", "force_loads",
                                        "output_loads"),
    "energy": ("contact_energy",),
    "ideal joint": ("ideal_joints", "ideal_contact_forces"),
    "reduced model's parameters and sensitivities": ("parameter_values", "floor_names",
                                                     "chain", "closure_rows",
                                                     "sensitivity_check", "fd_scale",
                                                     "trajectory_series"),
    "Exudyn element": ("exudyn_check", "exudyn_contact_scale", "exudyn_build",
                       "exudyn_ground_joints", "exudyn_series"),
}


class Element:
    """A joint kind: the class of its description, the `Linkage` field that holds its
    joints and the hooks of `PIECES`. Subclasses implement every hook; the base's raise
    NotImplementedError naming the element and the hook, so that a missing piece fails
    loudly where it is first needed."""

    #: the kind's name (the registry's key)
    kind: str = ""
    #: the description's dataclass of one joint of this kind
    description: type | None = None
    #: the `Linkage` field holding the joints of this kind
    attribute: str = ""
    #: the pieces of `PIECES` the element brings (every one unless a layer still writes
    #: the kind itself; that layer then iterates over `registry.elements_with(piece)`)
    pieces: tuple[str, ...] = tuple(PIECES)

    def joints(self, linkage) -> tuple:
        """The joints of this kind in `linkage`."""
        return tuple(getattr(linkage, self.attribute))

    @staticmethod
    def part(**fields) -> SimpleNamespace:
        """A record of the element's share of a derivation or a plan."""
        return SimpleNamespace(**fields)


def _absent(hook: str):
    def missing(self, *args, **kwargs):
        raise NotImplementedError(f"element {self.kind!r} has no {hook!r}")

    missing.__name__ = hook
    return missing


for _hook in (h for hooks in PIECES.values() for h in hooks):
    setattr(Element, _hook, _absent(_hook))
