"""The model generator: a `Linkage` -> its compiled, event-exact C model.

`generate_module(linkage)` derives the equations of the linkage's structure with
sympy.physics.mechanics (`derive`), plans their evaluation (`writer`, `jacobians`) and prints
the model in C (`cwriter`, `cjacobians`); `load_model(linkage)` returns the compiled model
(`c_loader.CModel`), built once per structure into the compiled-code cache (`core.build`).
"""


# the generator's names are imported on first use (sympy with them)
_LAZY = {"generate_module": ("c_loader", "generate_c_module"),
         "load_model": ("c_loader", "load_c_model"),
         "model_structure": ("key", "model_structure"),
         "GENERATOR_VERSION": ("key", "GENERATOR_VERSION"),
         "structure_digest": ("key", "structure_digest")}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        return getattr(importlib.import_module(f"{__name__}.{module}"), attr)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["generate_module", "load_model", "model_structure", "GENERATOR_VERSION",
           "structure_digest", "NAMED_CASES", "NAMED_VARIANTS", "named_cases"]

#: the named cases (functions of mbs_clearance.model.cases)
NAMED_CASES = ("paper_slider_crank", "slider_crank_two_clearances", "four_bar")

#: variants of named cases with another structure: name -> (case, overrides); the paper
#: case with friction in its joint (any law: a parameter)
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
