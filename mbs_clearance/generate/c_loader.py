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


def _c_generator_version() -> str:
    """Digest of everything a model's C text and library depend on besides its structure:
    the generator, the laws and the C headers (an edit of any changes every model's key)."""
    import hashlib

    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    files = sorted([*(root / "generate").glob("*.py"), *(root / "generate").glob("*.jinja"),
                    *(root / "laws").rglob("*.py"), *_CORE.glob("*.h")])
    for path in files:
        h.update(path.relative_to(root).as_posix().encode() + b"\0"
                 + path.read_bytes().replace(b"\r\n", b"\n") + b"\0")
    return h.hexdigest()


#: why a specialised model refuses a parameter vector (as the numba module's ZERO_MESSAGE)
ZERO_MESSAGE = ("a parameter of ZERO_PARAMETERS is not zero: this model is specialised on "
                "them; load the general one "
                "(mbs_clearance.generate.load_model(linkage, specialise=False))")


class CModel:
    """A compiled C model, usable where a plain run uses the generated numba module: its
    metadata as attributes (``model.N_STATE``, ``model.OUT_COLUMNS``, ...: read from the
    library, no derivation), and `prepare`, `closure`, `closure_jacobian`, `closure_rate`,
    `rhs`, `event`, `outputs` and `integrate_model` with the numba module's signatures,
    each a call into the compiled code. Also `ffi`, `lib` (cffi), `record`
    (``const mbs_model *``), the C `source` (made on first access: a sympy derivation) and
    the seconds its generation and build (or cache look-up) took."""

    def __init__(self, linkage, specialise, ffi, lib, rendered, generate_seconds,
                 build_seconds):
        import json

        self.linkage, self.specialise = linkage, specialise
        self.ffi, self.lib, self.record = ffi, lib, lib.mbs_model_record()
        self._rendered = rendered
        self.generate_seconds, self.build_seconds = generate_seconds, build_seconds
        meta = json.loads(ffi.string(lib.mbs_model_meta()).decode())
        self.meta = SimpleNamespace(**{k: tuple(v) if isinstance(v, list) else v
                                       for k, v in meta.items()})
        self.ZERO_MESSAGE = ZERO_MESSAGE
        self.__name__ = f"the C model of {linkage.name!r}"
        self._nc = int(lib.mbs_closure_size())

    @property
    def source(self) -> str:
        if not self._rendered:
            self._rendered.extend(_render(self.linkage, self.specialise))
        return self._rendered[0]

    def __getattr__(self, name):
        if name.startswith("_") or name in ("linkage", "specialise", "meta"):
            raise AttributeError(name)
        try:
            return getattr(self.meta, name)
        except AttributeError:
            raise AttributeError(f"CModel has no attribute {name!r}") from None

    def _ptr(self, a):
        return self.ffi.cast("double *", a.ctypes.data)

    def _vec(self, a, n=None):
        import numpy as np

        a = np.ascontiguousarray(a, dtype=np.float64)
        if n is not None and a.shape[0] < n:
            raise ValueError(f"expected at least {n} values; got {a.shape[0]}")
        return a

    def prepare(self, p) -> None:
        """The parameter-only constants into p[CONST_START:] (p: N_P float64, in place)."""
        if p.dtype != float or not p.flags.c_contiguous or p.shape[0] != self.N_P:
            raise ValueError(f"p must be a contiguous float64 array of N_P = {self.N_P} "
                             "entries")
        if self.record.prepare(self._ptr(p)):
            raise ValueError(ZERO_MESSAGE)

    def _closure(self, fn, t, q, p, size):
        import numpy as np

        q, p = self._vec(q, self.N_Q), self._vec(p, self.N_P)
        res = np.empty(size)
        fn(float(t), self._ptr(q), self._ptr(p), self._ptr(res))
        return res

    def closure(self, t, q, p):
        """Journal centre minus bearing centre of every clearance joint (then the sliders'
        offsets and tilts) at coordinates q: zero when the journals are centred."""
        return self._closure(self.lib.mbs_closure, t, q, p, self._nc)

    def closure_jacobian(self, t, q, p):
        """d closure / d q (nc, N_Q)."""
        return self._closure(self.lib.mbs_closure_jacobian, t, q, p,
                             self._nc * self.N_Q).reshape(self._nc, self.N_Q)

    def closure_rate(self, t, q, p):
        """d closure / d t at fixed q."""
        return self._closure(self.lib.mbs_closure_rate, t, q, p, self._nc)

    def rhs(self, t, y, p, dydt) -> None:
        """The state derivative into dydt (len(y) entries: a truncated state gives its
        own)."""
        n = y.shape[0]
        self.record.rhs(float(t), self._ptr(self._vec(y)), n, self._ptr(self._vec(p)),
                        self._ptr(dydt))

    def event(self, t, y, p, j):
        """(g, gdot) of switching function j."""
        import numpy as np

        out = np.empty(2)
        self.record.event(float(t), self._ptr(self._vec(y)), self._ptr(self._vec(p)),
                          int(j), self._ptr(out))
        return float(out[0]), float(out[1])

    def outputs(self, ts, ys, ms, p):
        """The outputs (n, N_OUT) at recorded steps: times ts, states ys, memories ms."""
        import numpy as np

        ys, ms = np.ascontiguousarray(ys, dtype=float), np.ascontiguousarray(ms, dtype=float)
        q = np.array(p, dtype=float)
        out = np.empty((len(ts), self.N_OUT))
        n, ne = ys.shape[1], max(self.N_EVENTS, 1)
        dydt, g, gd = np.empty(n), np.empty(ne), np.empty(ne)
        qp, dp, gp, gdp = self._ptr(q), self._ptr(dydt), self._ptr(g), self._ptr(gd)
        monitor, start = self.record.monitor, self.MEM_START
        for i in range(len(ts)):
            q[start:start + self.N_MEM] = ms[i, :self.N_MEM]
            row = out[i]
            monitor(float(ts[i]), self._ptr(ys[i]), n, qp, dp, self._ptr(row), self.N_OUT,
                    gp, gdp)
        return out

    def integrate_model(self, y0, p, edges, settings, coefficients):
        """The compiled core's run of this model (`core.integrate.integrate`; the numba
        module's integrate_model's arguments and returns)."""
        from ..core.integrate import integrate, model_record

        if self.record.prepare(self._ptr(self._vec(p).copy())):
            raise ValueError(ZERO_MESSAGE)
        return integrate(model_record(self.ffi, self.lib), y0, p, edges, settings,
                         coefficients)


def load_c_model(linkage: Linkage, specialise: bool = True) -> CModel:
    """The compiled C model of `linkage`'s structure (specialised on its zero-valued
    geometric parameters unless `specialise` is False): generated and compiled on first use,
    cached by the structure and the generator's digest (`_c_generator_version`: stale code
    never loads), one per structure and process."""
    from ..core import build

    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    if not isinstance(specialise, bool):
        raise ValueError(f"specialise must be True or False; got {specialise!r}")
    digest = structure_digest(model_structure(linkage, specialise))
    with _LOCK:
        if digest in _LOADED:
            return _LOADED[digest]
        rendered: list = []
        seconds = [0.0]

        def sources():
            started = time.perf_counter()
            rendered.extend(_render(linkage, specialise))
            seconds[0] = time.perf_counter() - started
            return [("model.c", rendered[0])] + [(name, (_CORE / name).read_text())
                                                 for name in C_SOURCES]

        started = time.perf_counter()
        ffi, lib = build.load(f"model-{digest[:16]}", sources,
                              key=f"{digest}\0{_c_generator_version()}")
        model = CModel(linkage, specialise, ffi, lib, rendered, seconds[0],
                       time.perf_counter() - started - seconds[0])
        _LOADED[digest] = model
        return model
