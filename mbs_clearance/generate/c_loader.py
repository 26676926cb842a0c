"""Generated models in C: the kernels of a linkage's structure printed in C (`cwriter`),
compiled with the system's C compiler into the compiled-code cache (`core.build`, keyed by
the digest of the source: stale code never loads) and opened with cffi.

`load_c_model(linkage)` returns a `CModel`: the cffi handles, the model record (sizes and
function pointers of the seam ``mbs_core.h``) and the metadata the numba module exposes
(PARAMETERS, OUT_COLUMNS, N_STATE, ...). The C source is generated on first use in a
process (sympy derivation, a few seconds) and kept for the process.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

from ..model.linkage import Linkage
from .key import model_structure, structure_digest

__all__ = ["generate_c_module", "load_c_model", "CModel", "C_SOURCES"]

_CORE = Path(__file__).resolve().parents[1] / "core"
#: the headers every model is compiled with (beside the seam's, which the build adds)
C_SOURCES = ("runtime.h", "laws_generated.h")
_LOCK = threading.Lock()
_LOADED: dict[str, CModel] = {}


def _render(linkage: Linkage, specialise: bool) -> tuple[str, dict]:
    from .cwriter import render_c
    from .derive import derive
    from .derive import specialise as specialised

    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    if not isinstance(specialise, bool):
        raise ValueError(f"specialise must be True or False; got {specialise!r}")
    structure = model_structure(linkage, specialise)
    zeros = tuple(structure.get("zero_parameters", ()))
    d = derive(linkage)
    return render_c(specialised(d, zeros) if zeros else d, linkage.name, structure, zeros)


def generate_c_module(linkage: Linkage, specialise: bool = True) -> str:
    """The C source of `linkage`'s model (deterministic: equal structures and zero sets
    give equal text); `specialise`: on its zero-valued geometric parameters."""
    return _render(linkage, specialise)[0]


@dataclass(frozen=True)
class CModel:
    """A compiled C model: `ffi`, `lib` (cffi), `record` (``const mbs_model *``), `meta`
    (the numba module's metadata, also as attributes: ``model.N_STATE``), the C `source`,
    and the seconds its generation and its build (or cache look-up) took."""

    ffi: object
    lib: object
    record: object
    meta: SimpleNamespace
    source: str
    generate_seconds: float
    build_seconds: float

    def __getattr__(self, name):
        try:
            return getattr(object.__getattribute__(self, "meta"), name)
        except AttributeError:
            raise AttributeError(f"CModel has no attribute {name!r}") from None


def load_c_model(linkage: Linkage, specialise: bool = True) -> CModel:
    """The compiled C model of `linkage`'s structure (specialised on its zero-valued
    geometric parameters unless `specialise` is False): generated and compiled on first use
    (cached by the source's digest), one per structure and process."""
    from ..core import build

    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    if not isinstance(specialise, bool):
        raise ValueError(f"specialise must be True or False; got {specialise!r}")
    digest = structure_digest(model_structure(linkage, specialise))
    with _LOCK:
        if digest in _LOADED:
            return _LOADED[digest]
        started = time.perf_counter()
        source, meta = _render(linkage, specialise)
        generated = time.perf_counter()
        sources = [("model.c", source)] + [(name, (_CORE / name).read_text())
                                           for name in C_SOURCES]
        ffi, lib = build.load(f"model-{digest[:16]}", sources)
        model = CModel(ffi=ffi, lib=lib, record=lib.mbs_model_record(),
                       meta=SimpleNamespace(**meta), source=source,
                       generate_seconds=generated - started,
                       build_seconds=time.perf_counter() - generated)
        _LOADED[digest] = model
        return model
