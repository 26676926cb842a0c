"""The model generator: a `Linkage` -> a compiled, event-exact numba model module.

`generate_module(linkage)` derives the equations of the linkage's structure with
sympy.physics.mechanics (`derive`) and writes the module's python source (`writer`, through
the jinja2 template module.py.jinja); `load_model(linkage)` returns the module, from the
checked-in modules of the named cases (mbs_clearance/_generated) or from a disk cache keyed
by the structure's digest (`loader`).
"""


# the generator's names are imported on first use (sympy and jinja2 with them): a generated
# module imports `generate.runtime` only, and with it this package
_LAZY = {"generate_module": "loader", "load_model": "loader", "model_path": "loader",
         "model_structure": "key", "GENERATOR_VERSION": "key", "structure_digest": "key"}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["generate_module", "load_model", "model_path", "model_structure", "GENERATOR_VERSION",
           "structure_digest", "NAMED_CASES", "NAMED_VARIANTS", "named_cases",
           "registry_source"]

#: the named cases (functions of mbs_clearance.model.cases) whose modules are checked in
NAMED_CASES = ("paper_slider_crank", "slider_crank_two_clearances", "four_bar")

#: checked-in variants of named cases with another structure: module name -> (case,
#: overrides); the paper case with friction in its joint (any law: a parameter)
NAMED_VARIANTS = {"paper_slider_crank_friction": ("paper_slider_crank",
                                                  {"friction_law": "ambrosio"})}


def named_cases() -> dict:
    """name -> Linkage (default arguments) of the NAMED_CASES that mbs_clearance.model.cases
    defines, and of the NAMED_VARIANTS."""
    from ..model import cases

    out = {name: getattr(cases, name)() for name in NAMED_CASES if hasattr(cases, name)}
    for name, (case, overrides) in NAMED_VARIANTS.items():
        if hasattr(cases, case):
            out[name] = getattr(cases, case)(**overrides)
    return out


def registry_source(cases: dict) -> str:
    """The source of mbs_clearance/_generated/__init__.py for the linkages `cases`."""
    from .key import model_structure, structure_digest

    lines = [f"    {structure_digest(model_structure(lk))!r}: {name!r},"
             for name, lk in cases.items()]
    return ('"""Checked-in generated model modules of the named cases (written by\n'
            'tools/generate_models.py; do not edit). MODULES maps a structure digest to a '
            'module name."""\n\nMODULES: dict[str, str] = {\n' + "\n".join(lines) + "\n}\n")
