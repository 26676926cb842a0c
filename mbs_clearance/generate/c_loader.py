"""Generated models in C: the kernels of a linkage's structure printed in C (`cwriter`),
compiled with the system's C compiler into the compiled-code cache (`core.build`, keyed by
the digest of the source: stale code never loads) and opened with cffi.

`load_c_model(linkage)` returns a `CModel`: the cffi handles, the model record (sizes and
function pointers of the seam ``mbs_core.h``) and the model's metadata
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
from functools import cached_property
from pathlib import Path
from types import SimpleNamespace

from .._warnings import CacheWarning
from ..model.linkage import Linkage
from .key import model_structure, structure_digest
from .profiles import bearing_kinematics

__all__ = ["generate_c_module", "load_c_model", "CModel", "C_SOURCES"]

_CORE = Path(__file__).resolve().parents[1] / "core"
#: the headers every model is compiled with (beside the seam's, which the build adds)
C_SOURCES = ("runtime.h", "laws_generated.h", "jac_runtime.h", "sens_runtime.h")
#: the header of the models with a profiled bearing
PROFILE_SOURCE = "profile_runtime.h"
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
    covers the derivation and the plan): the C printers, this loader and the profiles'
    layout."""
    h = hashlib.sha256()
    for name in ("cwriter.py", "cjacobians.py", "c_loader.py", "profiles.py"):
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
    d = specialised(d, zeros) if zeros else d
    profiles = {j: (*kin, len(linkage.clearance_joints[j].bearing_profile))
                for j, kin in bearing_kinematics(linkage, d).items()}
    return render_c(d, linkage.name, structure, zeros, profiles)


#: the named cases' model sources, shipped with the package (`tools/ship_models.py`): a
#: first run of a named case compiles without deriving; a structure or printer changed since
#: has another key and is derived as any description
SHIPPED = _HERE / "shipped"


def source_key(digest: str) -> str:
    """The key of a model's source: its structure's digest and the printer's version."""
    return hashlib.sha256(f"{digest}\0{_printer_version()}".encode()).hexdigest()[:24]


def _meta(data: dict) -> dict:
    return {k: tuple(v) if isinstance(v, list) else v for k, v in data["meta"].items()}


def _cached_render(linkage: Linkage, specialise: bool, digest: str) -> tuple[str, dict]:
    """`_render`, shipped with the package for the named cases (`SHIPPED`) or kept in the
    first usable cache directory (see the module docstring)."""
    from ..core import build

    key = source_key(digest)
    shipped = SHIPPED / f"model-source-{key}.json"
    if shipped.is_file():
        data = json.loads(shipped.read_text())
        return data["source"], _meta(data)
    rendered = None
    for directory in build.cache_dirs():
        if not build.usable(directory):
            continue
        path = directory / f"model-source-{key}.json"
        if build.valid(path):
            data = json.loads(path.read_text())
            return data["source"], _meta(data)
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
    (the model's metadata, also as attributes: ``model.N_STATE``), the C `source`,
    and the seconds its generation and its build (or cache look-up) took."""

    ffi: object
    lib: object
    record: object
    meta: SimpleNamespace
    source: str
    generate_seconds: float
    build_seconds: float

    def __post_init__(self):
        # the metadata as plain attributes: read on every run (a lookup through __getattr__
        # costs a Python call each); the class's own names keep precedence
        cls = type(self)
        self.__dict__.update({k: v for k, v in vars(self.meta).items() if not hasattr(cls, k)})

    def __getattr__(self, name):
        try:
            return getattr(object.__getattribute__(self, "meta"), name)
        except AttributeError:
            raise AttributeError(f"CModel has no attribute {name!r}") from None

    # ---- the functions of a plain run, each a call into the compiled code
    ZERO_MESSAGE = ("a parameter of ZERO_PARAMETERS is not zero: this model is specialised "
                    "on them; load the general one "
                    "(mbs_clearance.generate.load_model(linkage, specialise=False))")

    def _ptr(self, a):
        """A contiguous float64 array's data for the C functions (no copy; ValueError for a
        non-contiguous one)."""
        return self.ffi.from_buffer("double[]", a)

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

    def gap(self, t, y, p, j):
        """(ex, ey, exd, eyd) of switching function j's contact point: the journal centre
        minus the bearing centre (a corner: its position along and across the guide) and its
        rate, in m and m/s."""
        import numpy as np

        if not 0 <= int(j) < self.N_EVENTS:
            raise ValueError(f"j must be in [0, {self.N_EVENTS - 1}]; got {j}")
        y, p = self._vec(y), self._vec(p)
        g = np.empty(4)
        self.lib.mbs_gap(float(t), self._ptr(y), self._ptr(p), int(j), self._ptr(g))
        return float(g[0]), float(g[1]), float(g[2]), float(g[3])

    def gap_series(self, ts, ys, p, joints: int):
        """`gap` of switching functions 0 .. joints - 1 at recorded steps (times ts, states
        ys (n, >= 2 N_Q)): (n, joints, 4) (ex, ey, exd, eyd) in m and m/s."""
        import numpy as np

        ts, ys, p = self._vec(ts), self._vec(ys), self._vec(p)
        if ys.ndim != 2 or ys.shape[0] != ts.shape[0] or ys.shape[1] < 2 * self.N_Q \
                or p.shape[0] < self.N_P or not 0 <= joints <= self.N_EVENTS:
            raise ValueError(f"gap_series needs one state of >= {2 * self.N_Q} entries per "
                             f"time, p of {self.N_P} and 0 to {self.N_EVENTS} joints")
        out = np.empty((len(ts), joints, 4))
        ffi, lib = _series()
        gap = int(self.ffi.cast("uintptr_t", self.ffi.addressof(self.lib, "mbs_gap")))
        ptr = ffi.from_buffer
        lib.mbs_gap_series(gap, ffi.cast("double *", ptr(ts)), ffi.cast("double *", ptr(ys)),
                           len(ts), ys.shape[1], ffi.cast("double *", ptr(p)), joints,
                           ffi.cast("double *", ptr(out)))
        return out

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

    @cached_property
    def core_record(self):
        """The model's record as a pointer of the core's ffi (`core.integrate.model_record`)."""
        from ..core.integrate import model_record

        return model_record(self.ffi, self.lib)

    def integrate_model(self, y0, p, edges, settings, coefficients):
        """The compiled core's run of this model (`core.integrate.integrate`)."""
        from ..core.integrate import integrate

        # the zero check of prepare, without recomputing the constants on every run
        if any(p[i] != 0.0 for i in self.ZERO_INDEX):
            raise ValueError(self.ZERO_MESSAGE)
        return integrate(self.core_record, y0, p, edges, settings, coefficients)

    # ---- the sensitivity runs (DDM, tangents): the functions, same
    # arguments and returns
    def _no_profiles(self) -> None:
        """ValueError for a model with a profiled bearing: its Jacobian rows take circular
        bearings (`profiles.SENSITIVITY_RUNS`)."""
        if getattr(self.meta, "PROFILE_JOINTS", ()):
            from .profiles import SENSITIVITY_HINT, SENSITIVITY_RUNS

            raise ValueError(f"clearance joint {self.meta.PROFILE_JOINTS[0]!r} has a "
                             f"bearing_profile, which is not supported by {SENSITIVITY_RUNS}; "
                             f"{SENSITIVITY_HINT}")

    def _sens_record(self, n_p: int):
        """The sensitivity run's record for a p of n_p entries (`sens_runtime.h`)."""
        from ..core.integrate import core, with_parameter_length

        self._no_profiles()

        core_ffi, _ = core()
        address = int(self.ffi.cast("uintptr_t", self.lib.mbs_sens_model_record()))
        return with_parameter_length(core_ffi.cast("const mbs_model *", address), n_p)

    def _sens_p(self, p, n_y=None):
        """p checked to be a sensitivity run's parameter vector (the layout of
        `linkage_ddm.pack_sensitivity_parameters`) and n_y (if given) its state's length;
        returns (p, the number of directions)."""
        import numpy as np

        from .sens_runtime import work_size

        self._no_profiles()
        message = ("p must be a sensitivity run's parameter vector (a writable contiguous "
                   "float64 array, linkage_ddm.pack_sensitivity_parameters)")
        if not (isinstance(p, np.ndarray) and p.dtype == np.float64 and p.ndim == 1
                and p.flags.c_contiguous and p.flags.writeable) or p.shape[0] < self.N_P + 3:
            raise ValueError(message)
        nb, m = int(p[self.N_P]), int(p[self.N_P + 2])
        if nb < 1 or m < 1 or p.shape[0] != (self.N_P + 3 + 2 * nb * m + self.N_OUT + work_size(
                nb, self.N_Z, self.N_JROWS, self.N_Q, self.N_EVENTS)):
            raise ValueError(message + f"; its length {p.shape[0]} does not fit its header")
        n_state = 2 * self.N_Q * (1 + nb) + 1 + nb * self.N_EVENTS
        if n_y is not None and n_y != n_state:
            raise ValueError(f"the sensitivity state must have {n_state} entries for {nb} "
                             f"directions ([q, qdot, s_1 .. s_nb, W, sigma]); got {n_y}")
        return p, nb

    def integrate_sens(self, y0, p, edges, settings, coefficients):
        """The compiled core's run of the sensitivity equations (p: a sensitivity run's
        parameter vector, its memories and work entries updated in place)."""
        from ..core.integrate import integrate

        p, _ = self._sens_p(p, len(y0))
        if any(p[i] != 0.0 for i in self.ZERO_INDEX):
            raise ValueError(self.ZERO_MESSAGE)
        return integrate(self._sens_record(p.shape[0]), y0, p, edges, settings,
                         coefficients)

    def output_sensitivities(self, ts, ys, ms, p):
        """Values (n, N_OUT) and derivatives (n, N_OUT, nb) of the outputs along the
        integrated directions at recorded steps (times ts, sensitivity states ys, memories
        ms) of a sensitivity run with parameter vector p."""
        import numpy as np

        ts, ys, ms = self._vec(ts), self._vec(ys), self._vec(ms)
        n = ts.shape[0]
        if ys.ndim != 2 or ms.ndim != 2 or ys.shape[0] != n or ms.shape[0] != n \
                or ms.shape[1] > self.N_MEM:
            raise ValueError(f"ys and ms need one row per time ({n}), ms at most N_MEM = "
                             f"{self.N_MEM} columns")
        p, nb = self._sens_p(np.array(p, dtype=np.float64), ys.shape[1])
        vals, ders = np.empty((n, self.N_OUT)), np.empty((n, self.N_OUT, nb))
        if self.lib.mbs_output_sensitivities(
                self._ptr(ts), self._ptr(ys), n, ys.shape[1], self._ptr(ms), ms.shape[1],
                self._ptr(p), p.shape[0], self._ptr(vals), self._ptr(ders)):
            raise MemoryError("out of memory for a copy of the sensitivity parameters")
        return vals, ders

    def jacobian_matrix(self, t, y, p, full):
        """The Jacobian (N_JROWS, JAC_STRIDE) at (t, y): values and total derivatives along
        z (Z_NAMES) of the model's quantities in the contact modes of p."""
        import numpy as np

        self._no_profiles()
        y, p = self._vec(y), self._vec(p)
        jac = np.zeros((self.N_JROWS, self.JAC_STRIDE))
        self.lib.mbs_jacobian(float(t), self._ptr(y), self._ptr(p), self._ptr(jac),
                              int(bool(full)))
        return jac

    def tangent_matrix(self, t, y, p, dz, full):
        """The tangents (N_JROWS, nd + 1) at (t, y) along the seeds dz (nd, N_Z): the
        seeds' state columns passed as state sensitivities, where `tangent` reads them."""
        import numpy as np

        from .sens_runtime import seed_index

        self._no_profiles()
        y, p, dz = self._vec(y), self._vec(p), self._vec(dz)
        nd, n2 = dz.shape[0], 2 * self.N_Q
        out = np.zeros(self.N_JROWS * (nd + 1))
        use = np.zeros(dz.shape[1] + 1 + dz.size)
        seed_index(dz != 0.0, use)
        ys = np.empty(n2 * (1 + nd))
        ys[:n2] = y[:n2]
        for d in range(nd):
            ys[n2 * (1 + d):n2 * (2 + d)] = dz[d, 1:1 + n2]
        self.lib.mbs_tangent(float(t), self._ptr(ys), self._ptr(p), self._ptr(dz), nd,
                             self._ptr(use), self._ptr(out), int(bool(full)))
        return out.reshape(self.N_JROWS, nd + 1)

    def step_sens(self, t0, y0, p, hs, coefficients):
        """Steps of the sizes hs of the sensitivity equations from (t0, y0) (memories in
        p): states (len(hs), n) and the monitor's outputs (len(hs), N_OUT) at t0 + hs."""
        from ..core.integrate import step_states

        p, _ = self._sens_p(p, len(y0))
        return step_states(self._sens_record(p.shape[0]), t0, y0, p, hs, coefficients,
                           self.N_OUT)

    # ---- the step maps of recorded steps
    def refine_steps(self, t0s, y0s, mems, p, hs, coefficients, iters):
        """The maximum of the monitored value over the plain step map of each step k (start
        t0s[k] in s, state y0s[k], memories mems[k], size hs[k] in s), by golden section;
        returns (values, times in s)."""
        from ..core.integrate import step_peaks

        return step_peaks(self.core_record, t0s, y0s, mems, p, hs, coefficients, iters)

    def step_monitor_value(self, t0, y0, mem, p, h, coefficients):
        """The monitored value of the plain step map at t0 + h (state y0, memories mem)."""
        from ..core.integrate import step_value

        return step_value(self.core_record, t0, y0, mem, p, h, coefficients)


#: the series library's declarations (core/series.c)
SERIES_EXPORTS = """
void mbs_gap_series(uintptr_t gap, const double *ts, const double *ys, int64_t n,
                    int64_t width, const double *p, int64_t joints, double *out);
void mbs_window_norm_maxima(const double *s, int64_t ld, int64_t n2, const int64_t *ptr,
                            int64_t npar, const int64_t *rows, const double *vals,
                            const double *weights, const int64_t *lo, const int64_t *hi,
                            int64_t nw, double *out);
"""


_SERIES: list = []


def _series():
    """(ffi, lib) of core/series.c, built (or found in the cache) on first use."""
    from ..core import build

    with _LOCK:
        if not _SERIES:
            _SERIES.append(build.load("series", [("series.c", (_CORE / "series.c").read_text())],
                                      SERIES_EXPORTS))
        return _SERIES[0]


def window_norm_maxima(s, ptr, rows, vals, weights, lo, hi):
    """`linkage_ddm._window_norm_maxima` in one call of core/series.c (the same operations in
    the same order as its numpy formula): s (n, nb, n2) a view whose rows may be strided
    (a sensitivity run's states), (ptr, rows, vals) the coefficients by columns
    (`linkage_ddm._sparse_columns`), weights (npar, n2), windows lo, hi (nw,) of rows;
    returns (nw, npar)."""
    import numpy as np

    if s.ndim != 3 or s.strides[2] != 8 or s.strides[1] != 8 * s.shape[2] or s.strides[0] % 8:
        s = np.ascontiguousarray(s, dtype=np.float64)
    ptr, rows, lo, hi = (np.ascontiguousarray(a, dtype=np.int64) for a in (ptr, rows, lo, hi))
    vals = np.ascontiguousarray(vals, dtype=np.float64)
    weights = np.ascontiguousarray(weights, dtype=np.float64)
    n, nb, n2 = s.shape
    npar = ptr.shape[0] - 1
    if (weights.shape != (npar, n2) or lo.shape != hi.shape or np.any(lo < 0) or np.any(hi > n)
            or (rows.size and (rows.min() < 0 or rows.max() >= nb))
            or ptr[0] != 0 or ptr[-1] != rows.shape[0] or vals.shape != rows.shape):
        raise ValueError("window_norm_maxima: the shapes of s, the coefficients, the weights "
                         "and the windows do not fit")
    out = np.zeros((lo.shape[0], npar))
    if n == 0 or npar == 0:
        return out
    ffi, lib = _series()
    # the first element of s, whatever the base array (s may be a view into a wider one)
    base = ffi.cast("double *", s.__array_interface__["data"][0])
    lib.mbs_window_norm_maxima(base, s.strides[0] // 8, n2, ffi.from_buffer("int64_t[]", ptr),
                               npar, ffi.from_buffer("int64_t[]", rows),
                               ffi.from_buffer("double[]", vals),
                               ffi.from_buffer("double[]", weights),
                               ffi.from_buffer("int64_t[]", lo),
                               ffi.from_buffer("int64_t[]", hi), lo.shape[0],
                               ffi.from_buffer("double[]", out))
    return out


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
        # the profiles' header only where a model includes it: the other models' sources,
        # and so their libraries' keys, stay as they are
        headers = C_SOURCES + ((PROFILE_SOURCE,) if meta.get("PROFILE_JOINTS") else ())
        sources = [("model.c", source)] + [(name, (_CORE / name).read_text())
                                           for name in headers]
        ffi, lib = build.load(f"model-{digest[:16]}", sources, C_EXPORTS)
        model = CModel(ffi=ffi, lib=lib, record=lib.mbs_model_record(),
                       meta=SimpleNamespace(**meta), source=source,
                       generate_seconds=generated - started,
                       build_seconds=time.perf_counter() - generated)
        _LOADED[digest] = model
        return model
