"""Generated model modules: written once per structure, imported from disk.

A module is specialised on the linkage's geometric parameters that are exactly zero
(`key.geometric_zeros`: points on a body's axis, a guide through the origin; their terms
vanish from the equations): its key is the structure and that zero set
(`model_structure`), and its entries of p stay in place, checked to be zero. Pass
``specialise=False`` for the general module (derivatives along those parameters, by DDM or
finite differences, need it).

The checked-in modules of the named cases live in mbs_clearance/_generated (listed in its
``MODULES``, digest -> module name; `tools/generate_models.py` rewrites them, a test fails when
one is stale). Any other structure is generated on first use into the first writable of
``$MBS_CLEARANCE_MODEL_DIR/<library digest>``, ``mbs_clearance/_generated/__pycache__/models``,
the user's cache directory (keyed by the library digest too: numba's own cache of files
outside the package does not see edits of the library) and a private directory in the
temporary directory, as ``model_<digest[:16]>.py``, written atomically. The kernels of a
module inside the package are cached by the package's numba cache scheme (_cache.py), which
keys them by the library's sources.

A generated module is code that this process executes, so it is read only

- from a directory owned by the user that neither the group nor others can write (as numba's
  cache locator and the kernel cache's private temporary directory), and only if the file
  itself is owned by the user and writable by no one else; other directories are skipped;
- if its first line, the SHA-256 of the rest of its text (`DIGEST_HEADER`), matches that
  text, read once and executed from memory (no byte-code file, nothing read twice). A
  mismatch (a damaged or edited file) is never executed: the module is generated again, with
  a `CacheWarning`.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import stat
import sys
import tempfile
import threading
import warnings
from pathlib import Path
from types import ModuleType

from .._warnings import CacheWarning
from ..model.linkage import Linkage
from .c_loader import check_arguments
from .key import model_structure, structure_digest
from .profiles import refuse_profiles

__all__ = ["generate_module", "load_model", "model_path", "model_structure"]

_LOCK = threading.Lock()
_LOADED: dict[str, ModuleType] = {}
_PACKAGE = Path(__file__).resolve().parents[1]
#: the first line of a generated module in a cache directory, followed by the SHA-256 (hex)
#: of the text after that line
DIGEST_HEADER = "# mbs-clearance generated model, sha256 of the text below: "
#: why a generated module is not executed when its text differs from its digest line
DAMAGED = "does not match its recorded digest (its text changed after it was written)"
#: the largest generated module read (bytes); the named cases' are about 50 KB
MAX_MODULE_BYTES = 32 * 1024 * 1024


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
    """The directories a generated module may live in, in order of preference."""
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


def _owned_privately(st: os.stat_result) -> bool:
    """Whether `st` is owned by this user (where the system has user ids) and writable
    neither by the group nor by others."""
    getuid = getattr(os, "getuid", None)
    if getuid is not None and st.st_uid != getuid():
        return False
    return not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


def private_dir(path: Path) -> bool:
    """Whether `path` is a directory (not a symbolic link) owned by this user that neither the
    group nor others can write: the only kind a generated module is read from."""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    return stat.S_ISDIR(st.st_mode) and _owned_privately(st)


def _module_file(d: Path, digest: str) -> Path:
    return d / f"model_{digest[:16]}.py"


def model_path(linkage: Linkage, specialise: bool = True) -> Path | None:
    """Where `linkage`'s generated module is (None: not generated yet, or only in a
    directory it is not read from, see the module docstring)."""
    digest = structure_digest(model_structure(linkage, specialise))
    named = _named_modules().get(digest)
    if named is not None:
        return _PACKAGE / "_generated" / f"{named}.py"
    return _find(digest)


def _find(digest: str) -> Path | None:
    """The module file of `digest` in the first private directory holding one."""
    for d in _cache_dirs(digest):
        path = _module_file(d, digest)
        if private_dir(d) and path.is_file():
            return path
    return None


def _named_modules() -> dict[str, str]:
    from .._generated import MODULES

    return MODULES


def with_digest(source: str) -> str:
    """`source` behind its digest line (`DIGEST_HEADER`), as a cache directory holds it."""
    return f"{DIGEST_HEADER}{hashlib.sha256(source.encode()).hexdigest()}\n{source}"


def _write(digest: str, source: str) -> Path:
    """Write `source` behind its digest line atomically (readable by the user only) into the
    first private directory that can be made or written, else a private one in the
    temporary directory."""
    from .. import _cache

    last = None
    dirs = _cache_dirs(digest)
    for d in dirs:
        try:
            d.mkdir(mode=0o700, parents=True, exist_ok=True)
            if not private_dir(d):
                last = f"{d} is not a private directory of this user"
                continue
            return _write_in(d, digest, source)
        except OSError as exc:
            last = exc
    try:
        d = Path(_cache._private_temp_root()) / "models" / dirs[-1].name
        d.mkdir(mode=0o700, parents=True, exist_ok=True)
        if private_dir(d):
            return _write_in(d, digest, source)
    except OSError as exc:
        last = exc
    raise OSError(f"no writable private directory for the generated model: {last}")


def _write_in(d: Path, digest: str, source: str) -> Path:
    path = _module_file(d, digest)
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".model-", suffix=".tmp")    # mode 0600
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(with_digest(source))
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def _verified_text(path: Path, digest: str) -> tuple[str | None, str]:
    """(the text of the module file at `path`, "") if it is a private file of this user
    whose digest line matches the rest and that was generated for `digest`; else (None,
    why not): `DAMAGED` when the text does not match its digest line."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    except OSError as exc:
        return None, f"cannot be opened ({exc.strerror or exc})"
    with os.fdopen(fd, "rb") as fh:
        st = os.fstat(fh.fileno())
        if not stat.S_ISREG(st.st_mode) or not _owned_privately(st):
            return None, "is not a private file of this user"
        data = fh.read(MAX_MODULE_BYTES + 1)
    if len(data) > MAX_MODULE_BYTES:
        return None, f"is larger than {MAX_MODULE_BYTES} bytes"
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return None, "is not UTF-8 text"
    head, sep, rest = text.partition("\n")
    if not sep or not head.startswith(DIGEST_HEADER):
        return None, "has no digest line"
    if head[len(DIGEST_HEADER):] != hashlib.sha256(rest.encode()).hexdigest():
        return None, DAMAGED
    if f'STRUCTURE_DIGEST = "{digest}"' not in rest[:20000]:
        return None, "was generated for another structure or generator version"
    return text, ""


def load_model(linkage: Linkage, specialise: bool = True) -> ModuleType:
    """The generated model module of `linkage`'s structure (specialised on its zero-valued
    geometric parameters unless `specialise` is False): a checked-in one, a cached one, or
    generated now (sympy derivation, a few seconds; the first compile of its kernels follows
    on first use). A cached module is executed only if it passes the checks of the module
    docstring; one that fails them is generated again (with a `CacheWarning` if its text
    does not match its digest)."""
    check_arguments(linkage, specialise)
    refuse_profiles(linkage)
    digest = structure_digest(model_structure(linkage, specialise))
    with _LOCK:
        if digest in _LOADED:
            return _LOADED[digest]
        named = _named_modules().get(digest)
        if named is not None:
            module = importlib.import_module(f"mbs_clearance._generated.{named}")
        else:
            path = _find(digest)
            text, why = (None, "") if path is None else _verified_text(path, digest)
            if text is None:
                if why == DAMAGED:
                    warnings.warn(f"generated model {str(path)!r} {why}; it is not executed "
                                  "but generated again", CacheWarning, stacklevel=2)
                source = generate_module(linkage, specialise)
                path = _write(digest, source)
                text = with_digest(source)
            module = _execute(f"mbs_clearance_model_{digest[:16]}", path, text)
        if getattr(module, "STRUCTURE_DIGEST", None) != digest:
            raise RuntimeError(f"generated model {module.__file__} is not the one of this "
                               "structure (stale); regenerate it")
        _LOADED[digest] = module
        return module


def _execute(name: str, path: Path, text: str) -> ModuleType:
    """A module `name` made by executing `text` (the verified text of the file at `path`,
    which it names as its file: numba's cache and tracebacks refer to it)."""
    code = compile(text, str(path), "exec", dont_inherit=True)
    module = ModuleType(name)
    module.__file__ = str(path)
    sys.modules[name] = module
    try:
        exec(code, module.__dict__)     # noqa: S102 - our own generated text, verified
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def _current(path: Path, digest: str) -> bool:
    """Whether the file at `path` is a verified module generated for `digest` by this
    generator version."""
    return _verified_text(path, digest)[0] is not None
