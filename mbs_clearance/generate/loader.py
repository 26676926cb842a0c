"""Generated model modules: written once per structure, imported from disk.

A module is specialised on the linkage's geometric parameters that are exactly zero
(`derive.geometric_zeros`: points on a body's axis, a guide through the origin; their terms
vanish from the equations): its key is the structure and that zero set
(`model_structure`), and its entries of p stay in place, checked to be zero. Pass
``specialise=False`` for the general module (derivatives along those parameters, by DDM or
finite differences, need it).

The checked-in modules of the named cases live in mbs_clearance/_generated (listed in its
``MODULES``, digest -> module name; `tools/generate_models.py` rewrites them, a test fails when
one is stale). Any other structure is generated on first use into the first writable of
``$MBS_CLEARANCE_MODEL_DIR/<library digest>``, ``mbs_clearance/_generated/__pycache__/models``
and the user's cache directory (keyed by the library digest too: numba's own cache of files
outside the package does not see edits of the library), as ``model_<digest[:16]>.py``,
written atomically. The kernels of a module inside the package are cached by the package's numba
cache scheme (_cache.py), which keys them by the library's sources.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import sys
import tempfile
import threading
from pathlib import Path
from types import ModuleType

from ..linkage import Linkage
from .writer import structure_digest

__all__ = ["generate_module", "load_model", "model_path", "model_structure"]

_LOCK = threading.Lock()
_LOADED: dict[str, ModuleType] = {}
_PACKAGE = Path(__file__).resolve().parents[1]


def model_structure(linkage: Linkage, specialise: bool = True) -> dict:
    """What `linkage`'s generated module depends on: its structure (`Linkage.structure`)
    and, when specialised, the geometric parameters that are exactly zero in it."""
    from .derive import geometric_zeros

    structure = linkage.structure()
    zeros = geometric_zeros(linkage) if specialise else ()
    if zeros:
        structure["zero_parameters"] = list(zeros)
    return structure


def generate_module(linkage: Linkage, specialise: bool = True) -> str:
    """The python source of `linkage`'s model module (deterministic: equal structures and
    zero sets give equal text); `specialise`: on its zero-valued geometric parameters."""
    from .derive import derive
    from .derive import specialise as specialised
    from .writer import render

    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    structure = model_structure(linkage, specialise)
    zeros = tuple(structure.get("zero_parameters", ()))
    d = derive(linkage)
    return render(specialised(d, zeros) if zeros else d, linkage.name, structure, zeros)


def _cache_dirs(digest: str) -> list[Path]:
    from numba.misc.appdirs import AppDirs

    from .. import _cache

    # outside the package numba's own cache applies, which does not see edits of the
    # library: those directories are keyed by the library's digest too
    lib = _cache._PACKAGES.get(str(_PACKAGE))
    tag = lib.digest[:12] if lib is not None else "unversioned"
    dirs = []
    env = os.environ.get("MBS_CLEARANCE_MODEL_DIR")
    if env:
        dirs.append(Path(env) / tag)
    dirs.append(_PACKAGE / "_generated" / "__pycache__" / "models")
    dirs.append(Path(AppDirs(appname="mbs_clearance", appauthor=False).user_cache_dir)
                / "models" / tag)
    return dirs


def model_path(linkage: Linkage, specialise: bool = True) -> Path | None:
    """Where `linkage`'s generated module is (None: not generated yet)."""
    digest = structure_digest(model_structure(linkage, specialise))
    named = _named_modules().get(digest)
    if named is not None:
        return _PACKAGE / "_generated" / f"{named}.py"
    for d in _cache_dirs(digest):
        path = d / f"model_{digest[:16]}.py"
        if path.is_file():
            return path
    return None


def _named_modules() -> dict[str, str]:
    from .._generated import MODULES

    return MODULES


def _write(digest: str, source: str) -> Path:
    """Write `source` atomically into the first writable cache directory."""
    last = None
    for d in _cache_dirs(digest):
        try:
            d.mkdir(parents=True, exist_ok=True)
            path = d / f"model_{digest[:16]}.py"
            fd, tmp = tempfile.mkstemp(dir=d, prefix=".model-", suffix=".tmp")
            with os.fdopen(fd, "w") as fh:
                fh.write(source)
            os.replace(tmp, path)
            return path
        except OSError as exc:
            last = exc
    raise OSError(f"no writable directory for the generated model: {last}")


def load_model(linkage: Linkage, specialise: bool = True) -> ModuleType:
    """The generated model module of `linkage`'s structure (specialised on its zero-valued
    geometric parameters unless `specialise` is False): a checked-in one, a cached one, or
    generated now (sympy derivation, a few seconds; the first compile of its kernels follows
    on first use)."""
    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    if not isinstance(specialise, bool):
        raise ValueError(f"specialise must be True or False; got {specialise!r}")
    digest = structure_digest(model_structure(linkage, specialise))
    with _LOCK:
        if digest in _LOADED:
            return _LOADED[digest]
        named = _named_modules().get(digest)
        if named is not None:
            module = importlib.import_module(f"mbs_clearance._generated.{named}")
        else:
            path = model_path(linkage, specialise)
            if path is None or not _current(path, digest):
                path = _write(digest, generate_module(linkage, specialise))
            name = f"mbs_clearance_model_{digest[:16]}"
            spec = importlib.util.spec_from_file_location(name, path)
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module
            spec.loader.exec_module(module)
        if getattr(module, "STRUCTURE_DIGEST", None) != digest:
            raise RuntimeError(f"generated model {module.__file__} is not the one of this "
                               "structure (stale); regenerate it")
        _LOADED[digest] = module
        return module


def _current(path: Path, digest: str) -> bool:
    """Whether the file at `path` was generated for `digest` by this generator version."""
    try:
        head = path.read_text()[:20000]
    except OSError:
        return False
    return f'STRUCTURE_DIGEST = "{digest}"' in head
