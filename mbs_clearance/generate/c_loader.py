"""Generated models in C: the kernels of a linkage's structure printed in C (`cwriter`),
compiled with the system's C compiler into the compiled-code cache (`core.build`, keyed by
the digest of the source: stale code never loads) and opened with cffi.

`load_c_model(linkage)` returns a `CModel`: the cffi handles, the model record (sizes and
function pointers of the seam ``mbs_core.h``) and the metadata the numba module exposes
(PARAMETERS, OUT_COLUMNS, N_STATE, ...). The C source is generated on first use (sympy
derivation, one to ten seconds) and kept, with its metadata, in the compiled-code cache
beside the libraries, keyed by the structure's digest and the C printer's sources; it is
read back under the same rules as a library (a trusted directory, a private file whose
SHA-256 matches the one recorded when it was written; anything else is generated again).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import threading
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

from .._warnings import CacheWarning
from ..model.linkage import Linkage
from .key import model_structure, structure_digest

__all__ = ["generate_c_module", "load_c_model", "CModel", "C_SOURCES"]

_CORE = Path(__file__).resolve().parents[1] / "core"
#: the headers every model is compiled with (beside the seam's, which the build adds)
C_SOURCES = ("runtime.h", "laws_generated.h", "jac_runtime.h", "sens_runtime.h")
_HERE = Path(__file__).resolve().parent
#: what a model library exports beside the seam's record and closure (cffi declarations)
C_EXPORTS = """
void mbs_gap(double t, const double *y, const double *p, int64_t j, double *g);
void mbs_jacobian(double t, const double *y, const double *p, double *jac, int64_t full);
void mbs_tangent(double t, const double *y, const double *p, const double *dz, int64_t nd,
                 const double *use, double *out, int64_t full);
const mbs_model *mbs_sens_model_record(void);
int64_t mbs_output_sensitivities(const double *ts, const double *ys, int64_t n, int64_t n_y,
                                 const double *ms, int64_t n_m, const double *p, int64_t n_p,
                                 double *vals, double *ders);
"""
_LOG = logging.getLogger("mbs_clearance")
_LOCK = threading.Lock()
_LOADED: dict[str, CModel] = {}


def check_arguments(linkage, specialise) -> None:
    """ValueError unless `linkage` is a Linkage and `specialise` True or False."""
    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    if not isinstance(specialise, bool):
        raise ValueError(f"specialise must be True or False; got {specialise!r}")


def _printer_version() -> str:
    """The digest of what makes a model's C source besides its structure (whose digest
    covers the derivation and the plan): the C printer and this loader."""
    h = hashlib.sha256()
    for name in ("cwriter.py", "c_loader.py"):
        h.update((_HERE / name).read_bytes().replace(b"\r\n", b"\n") + b"\0")
    return h.hexdigest()[:16]


def _render(linkage: Linkage, specialise: bool) -> tuple[str, dict]:
    from .cwriter import render_c
    from .derive import derive
    from .derive import specialise as specialised

    check_arguments(linkage, specialise)
    structure = model_structure(linkage, specialise)
    zeros = tuple(structure.get("zero_parameters", ()))
    d = derive(linkage)
    return render_c(specialised(d, zeros) if zeros else d, linkage.name, structure, zeros)


def _cached_render(linkage: Linkage, specialise: bool, digest: str) -> tuple[str, dict]:
    """`_render`, kept in the first usable cache directory (see the module docstring)."""
    from ..core import build

    key = hashlib.sha256(f"{digest}\0{_printer_version()}".encode()).hexdigest()[:24]
    rendered = None
    for directory in build.cache_dirs():
        if not build.usable(directory):
            continue
        path = directory / f"model-source-{key}.json"
        if build.valid(path):
            data = json.loads(path.read_text())
            meta = {k: tuple(v) if isinstance(v, list) else v for k, v in data["meta"].items()}
            return data["source"], meta
        if path.exists():
            warnings.warn(f"the generated model source {path} does not match its recorded "
                          "digest (damaged or changed); it is generated again", CacheWarning,
                          stacklevel=3)
        rendered = rendered or _render_logged(linkage, specialise)
        part = path.with_name(f"{path.name}.part-{os.getpid()}-{threading.get_ident()}")
        try:
            part.write_text(json.dumps({"source": rendered[0], "meta": rendered[1]}))
            os.chmod(part, 0o600)
            build.stamp(part, path)
            return rendered
        except OSError:          # full or read-only: the next place
            continue
        finally:
            part.unlink(missing_ok=True)
    return rendered or _render_logged(linkage, specialise)


def _render_logged(linkage: Linkage, specialise: bool) -> tuple[str, dict]:
    """`_render`, said first (a derivation takes one to ten seconds)."""
    _LOG.info("deriving the model of linkage %r in C (first use of its structure only)",
              linkage.name)
    return _render(linkage, specialise)


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

    # ---- the numba module's functions of a plain run, each a call into the compiled code
    ZERO_MESSAGE = ("a parameter of ZERO_PARAMETERS is not zero: this model is specialised "
                    "on them; load the general one "
                    "(mbs_clearance.generate.load_model(linkage, specialise=False))")

    def _ptr(self, a):
        return self.ffi.cast("double *", a.ctypes.data)

    @staticmethod
    def _vec(a):
        import numpy as np

        return np.ascontiguousarray(a, dtype=np.float64)

    def prepare(self, p) -> None:
        """The parameter-only constants into p[CONST_START:] (p: N_P float64, in place)."""
        if p.dtype != float or not p.flags.c_contiguous or p.shape[0] != self.N_P:
            raise ValueError(f"p must be a contiguous float64 array of N_P = {self.N_P} "
                             "entries")
        if self.record.prepare(self._ptr(p)):
            raise ValueError(self.ZERO_MESSAGE)

    def _closure(self, fn, t, q, p, size):
        import numpy as np

        q, p = self._vec(q), self._vec(p)
        if q.shape[0] < self.N_Q or p.shape[0] < self.N_P:
            raise ValueError(f"q needs {self.N_Q} and p {self.N_P} entries")
        res = np.empty(size)
        fn(float(t), self._ptr(q), self._ptr(p), self._ptr(res))
        return res

    def closure(self, t, q, p):
        """Journal centre minus bearing centre of every clearance joint (then the sliders'
        offsets and tilts) at coordinates q: zero when the journals are centred."""
        return self._closure(self.lib.mbs_closure, t, q, p, self.lib.mbs_closure_size())

    def closure_jacobian(self, t, q, p):
        """d closure / d q (nc, N_Q)."""
        nc = self.lib.mbs_closure_size()
        return self._closure(self.lib.mbs_closure_jacobian, t, q, p,
                             nc * self.N_Q).reshape(nc, self.N_Q)

    def closure_rate(self, t, q, p):
        """d closure / d t at fixed q."""
        return self._closure(self.lib.mbs_closure_rate, t, q, p, self.lib.mbs_closure_size())

    def rhs(self, t, y, p, dydt) -> None:
        """The state derivative into dydt (len(y) entries: a truncated state gives its
        own)."""
        y = self._vec(y)
        self.record.rhs(float(t), self._ptr(y), y.shape[0], self._ptr(self._vec(p)),
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

        ys, ms = self._vec(ys), self._vec(ms)
        q = np.array(p, dtype=float)
        out = np.empty((len(ts), self.N_OUT))
        n, ne = ys.shape[1], max(self.N_EVENTS, 1)
        dydt, g, gd = np.empty(n), np.empty(ne), np.empty(ne)
        qp, dp, gp, gdp = self._ptr(q), self._ptr(dydt), self._ptr(g), self._ptr(gd)
        monitor, start = self.record.monitor, self.MEM_START
        for i in range(len(ts)):
            q[start:start + self.N_MEM] = ms[i, :self.N_MEM]
            monitor(float(ts[i]), self._ptr(ys[i]), n, qp, dp, self._ptr(out[i]), self.N_OUT,
                    gp, gdp)
        return out

    def integrate_model(self, y0, p, edges, settings, coefficients):
        """The compiled core's run of this model (`core.integrate.integrate`; the numba
        module's integrate_model's arguments and returns)."""
        from ..core.integrate import integrate, model_record

        # the zero check of prepare, without recomputing the constants on every run
        if any(p[i] != 0.0 for i in self.ZERO_INDEX):
            raise ValueError(self.ZERO_MESSAGE)
        return integrate(model_record(self.ffi, self.lib), y0, p, edges, settings,
                         coefficients)

    # ---- the step maps of recorded steps (the numba module's, same arguments and returns)
    def refine_steps(self, t0s, y0s, mems, p, hs, coefficients, iters):
        """The maximum of the monitored value over the plain step map of each step k (start
        t0s[k] in s, state y0s[k], memories mems[k], size hs[k] in s), by golden section;
        returns (values, times in s)."""
        from ..core.integrate import model_record, step_peaks

        return step_peaks(model_record(self.ffi, self.lib), t0s, y0s, mems, p, hs,
                          coefficients, iters)

    def step_monitor_value(self, t0, y0, mem, p, h, coefficients):
        """The monitored value of the plain step map at t0 + h (state y0, memories mem)."""
        from ..core.integrate import model_record, step_value

        return step_value(model_record(self.ffi, self.lib), t0, y0, mem, p, h, coefficients)


def load_c_model(linkage: Linkage, specialise: bool = True) -> CModel:
    """The compiled C model of `linkage`'s structure (specialised on its zero-valued
    geometric parameters unless `specialise` is False): generated and compiled on first use
    (cached by the source's digest), one per structure and process."""
    from ..core import build

    check_arguments(linkage, specialise)
    digest = structure_digest(model_structure(linkage, specialise))
    with _LOCK:
        if digest in _LOADED:
            return _LOADED[digest]
        started = time.perf_counter()
        source, meta = _cached_render(linkage, specialise, digest)
        generated = time.perf_counter()
        sources = [("model.c", source)] + [(name, (_CORE / name).read_text())
                                           for name in C_SOURCES]
        ffi, lib = build.load(f"model-{digest[:16]}", sources, C_EXPORTS)
        model = CModel(ffi=ffi, lib=lib, record=lib.mbs_model_record(),
                       meta=SimpleNamespace(**meta), source=source,
                       generate_seconds=generated - started,
                       build_seconds=time.perf_counter() - generated)
        _LOADED[digest] = model
        return model
