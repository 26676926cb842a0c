"""Keep numba's on-disk cache of the compiled kernels consistent with their sources.

numba checks a cached kernel against its *own* source file only, but a kernel contains the
code of every function it calls: a generated model's `rhs` inlines laws/forces.py and
numerics/_trig.py, `validation.stress._step_excursion` inlines generate/runtime.py and
numerics/integrator.py. After an edit of such a helper numba would go on loading the old
machine code. And a process that imported
the old sources but compiles after the edit would write old code into the cache for everyone.

A package that calls `register_package` in its ``__init__`` (mbs_clearance; validation with
``depends_on=("mbs_clearance",)``) gets a cache locator of its own, tried before numba's:

- the digest of the package's sources (every ``*.py`` under it, plus the digests of the
  packages it depends on) is taken once, when the process imports the package;
- the kernels of the package are cached under ``__pycache__/nb-<digest[:12]>/`` beside
  their file, and the full digest is their source stamp. A process compiling code it
  imported before an edit writes under the old key, which no process with the new sources
  looks at. If the sources change while the package is being imported (the process then
  holds a mix), the kernels still defined after that change get a stamp no other process
  can match, so nothing of that mix is ever loaded elsewhere;
- cache directories of other digests (and numba's own cache files of the package, from
  before this scheme) that were not written to for `PRUNE_AGE` seconds are removed;
- where ``__pycache__`` is not writable: under ``NUMBA_CACHE_DIR`` if set (it is tried
  first), else numba's user-wide cache directory, else a directory of the user's own in the
  temporary directory, with one `CacheWarning` per process.

A shared kernel that takes kernels as arguments (`integrator.integrate` and its stages) has
one index for all the models it was compiled for, and reading it imports each of their
modules. A model generated on demand (`generate.load_model`) is imported from a file, not by
name, so a process that has not loaded it cannot read such an index: numba would raise
ModuleNotFoundError at the first compile of any other model. Such an index is read as empty
here (`_load_index_or_empty`): the kernel is compiled and the index rewritten with it.

A damaged cache file (an index ``.nbi`` or a data file ``.nbc`` cut short by a full disk or a
killed process, or overwritten) would make numba raise ``UnpicklingError`` or ``EOFError`` on
every later run. Reading one here (`_load_index_or_empty`, `_load_data_or_none`) drops the
file and reads it as a cache miss: the kernel is compiled again and the entry rewritten, with
one `CacheWarning` per process naming the file.

Every compiled-kernel cache (numba's today; any other compiler's through the same
functions) keeps the rules of the generated models' cache:

- a directory is read only if it is owned by the user and not writable by group or others
  (`untrusted`, checked from the cache's root down to the kernel's directory); another one
  is never read, with one `CacheWarning` naming it, and the next place is tried;
- every entry is written with the SHA-256 digest of its bytes in front (`write_entry`,
  atomically) and read only when the digest matches (`read_entry`): a damaged entry is
  dropped before anything unpickles it;
- a cache that cannot be read or written (a damaged or stale entry that fails, a directory
  where an index belongs, a full disk, a read-only directory) is dropped for the rest of
  the process with one `CacheWarning` naming the path (`drop_cache`), and the run goes on
  compiling in memory.

When a kernel of a registered package is not in the cache (numba's "numba:compile" event
fires on cache misses only), the logger "mbs_clearance" says so once, at INFO: "compiling
kernels (first run only, about N s)", N being the longest compilation measured so far
(kept in ``__pycache__/compile-seconds.txt``), then progress every few seconds.
"""

from __future__ import annotations

import atexit
import hashlib
import importlib
import logging
import os
import pickle
import shutil
import stat
import sys
import tempfile
import time
import uuid
import warnings
from dataclasses import dataclass
from pathlib import Path

import numba
from numba.core import caching, config
from numba.core import event as numba_event
from numba.core.caching import _CacheLocator
from numba.misc.appdirs import AppDirs

from ._warnings import CacheWarning

__all__ = ["register_package", "sources_digest", "PREFIX", "PRUNE_AGE", "untrusted",
           "read_entry", "write_entry", "drop_cache", "cache_dropped", "ENTRY_MAGIC"]

#: name prefix of the cache directories, followed by the first 12 hex digits of the digest
PREFIX = "nb-"
#: cache directories of other digests unused for this many seconds are removed
PRUNE_AGE = 600.0
# numba's cache files in the default places and the digest file of the scheme before this one
_LEGACY = (".nbi", ".nbc", "mbs_clearance_sources.sha256")
# the base of numba's cache implementations, whose list of locators is tried in order
CacheImpl = getattr(caching, "CacheImpl", None) or caching._CacheImpl   # older numba
_NUMBA_DIR = os.path.dirname(os.path.abspath(numba.__file__)) + os.sep


def _source_files(root: Path) -> list[Path]:
    # called for every kernel defined: the walk skips the __pycache__ folders (the kernel
    # caches, hundreds of files) instead of listing them and filtering
    found = []
    for folder, subfolders, names in os.walk(root):
        subfolders[:] = [d for d in subfolders if d != "__pycache__"]
        found.extend(Path(folder) / n for n in names if n.endswith(".py"))
    return sorted(found)


def _stat_signature(files: list[Path]) -> tuple:
    sig = []
    for path in files:
        try:
            st = path.stat()
            sig.append((st.st_mtime_ns, st.st_size))
        except OSError:
            sig.append(None)
    return tuple(sig)


def sources_digest(root: Path, extra: tuple[str, ...] = ()) -> str:
    """SHA-256 over the package's Python sources (relative paths and contents, sorted by
    path, subpackages included) followed by the digests `extra` of its dependencies."""
    h = hashlib.sha256()
    for path in _source_files(root):
        h.update(path.relative_to(root).as_posix().encode() + b"\0")
        h.update(path.read_bytes() + b"\0")
    for digest in extra:
        h.update(digest.encode())
    return h.hexdigest()


@dataclass
class _Package:
    name: str
    root: str                       # realpath of the package directory
    digest: str                     # at import
    depends_on: tuple[_Package, ...]
    files: list[Path]
    signature: tuple                # stat signature of `files` at import

    def unchanged(self) -> bool:
        """True while the sources are the ones the digest was taken from."""
        if _stat_signature(self.files) != self.signature or _source_files(
                Path(self.root)) != self.files:
            try:
                now = sources_digest(Path(self.root), tuple(d.digest for d in self.depends_on))
            except OSError:
                return False
            if now != self.digest:
                return False
            self.signature = _stat_signature(self.files)
        return all(d.unchanged() for d in self.depends_on)


_PACKAGES: dict[str, _Package] = {}     # realpath of root -> package
_DIRS: dict[tuple[str, str], str | None] = {}  # (source directory, name) -> cache directory
_WARNED: set[str] = set()      # kinds of CacheWarning given in this process


log = logging.getLogger("mbs_clearance")
#: file (in the package's __pycache__) with the seconds the last full compilation took
COMPILE_SECONDS = "compile-seconds.txt"
#: seconds between two progress messages while kernels compile
PROGRESS_EVERY = 10.0


class CompileListener(numba_event.Listener):
    """Logs when the kernels of a registered package compile (cache misses only): one
    "compiling kernels" line with the expected time, then progress."""

    def __init__(self):
        self.t0 = None
        self.last = 0.0
        self.count = 0
        self.depth = 0
        self.package = None

    def _ours(self, event) -> _Package | None:
        dispatcher = (event.data or {}).get("dispatcher")
        code = getattr(getattr(dispatcher, "py_func", None), "__code__", None)
        return None if code is None else _package_of(code.co_filename)

    def on_start(self, event):
        package = self._ours(event)
        if package is None:
            return
        self.depth += 1
        if self.t0 is None:
            self.t0 = self.last = time.perf_counter()
            self.package = package
            seconds = _read_seconds(package)
            about = f"about {seconds:.0f} s" if seconds else "a minute or more"
            log.info(f"compiling kernels (first run only, {about}; later runs load them "
                     f"from the cache)")

    def on_end(self, event):
        if self._ours(event) is None:
            return
        self.depth -= 1
        self.count += 1
        now = time.perf_counter()
        if self.depth == 0:
            _write_seconds(self.package, now - self.t0)
            if now - self.last >= PROGRESS_EVERY:
                self.last = now
                name = getattr(event.data["dispatcher"], "__name__", "?")
                log.info(f"compiling kernels: {self.count} done ({name}), "
                         f"{now - self.t0:.0f} s so far")


def _seconds_file(package: _Package) -> Path:
    return Path(package.root) / "__pycache__" / COMPILE_SECONDS


def _read_seconds(package: _Package) -> float | None:
    try:
        return float(_seconds_file(package).read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def _write_seconds(package: _Package, seconds: float) -> None:
    """Keep the longest compilation seen (a run that uses few kernels compiles few)."""
    if seconds < 1.0 or seconds <= (_read_seconds(package) or 0.0):
        return
    try:
        _seconds_file(package).write_text(f"{seconds:.1f}\n")
    except OSError:
        pass        # a read-only install: the estimate stays unknown


_LISTENER: CompileListener | None = None


# ---------------------------------------------------------------- the rules of any cache

#: first bytes of a cache entry, followed by the SHA-256 digest of the rest (32 bytes)
ENTRY_MAGIC = b"mbs-clearance-kernel-cache-1\n"
_DROPPED: dict[str, str] = {}      # cache directory -> why it is not used in this process


def untrusted(path: str, root: str | None = None) -> str | None:
    """Why the directory `path` must not be read, or None if it may: it, and every
    directory from `root` (default: `path` alone) down to it, must be a directory owned by
    this user and not writable by group or others (a directory others can write to could
    hold entries made to run code when they are unpickled)."""
    uid = getattr(os, "geteuid", lambda: None)()
    path = os.path.abspath(path)
    chain = [path]
    if root is not None:
        root = os.path.abspath(root)
        head = path
        while head != root and os.path.dirname(head) != head:
            head = os.path.dirname(head)
            chain.append(head)
    for folder in chain:
        try:
            st = os.stat(folder)
        except OSError as exc:
            return f"{folder} cannot be inspected ({exc.strerror or exc})"
        if not stat.S_ISDIR(st.st_mode):
            return f"{folder} is not a directory"
        if uid is not None and st.st_uid != uid:
            return f"{folder} is owned by another user (uid {st.st_uid})"
        if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            return (f"{folder} is writable by group or others (mode "
                    f"{stat.S_IMODE(st.st_mode):o})")
    return None


def cache_dropped(directory: str) -> bool:
    """Whether the cache in `directory` was dropped for this process (`drop_cache`)."""
    return os.path.abspath(directory) in _DROPPED


def drop_cache(directory: str, path: str, exc: BaseException | str) -> None:
    """Stop using the cache in `directory` for the rest of the process after a problem
    with `path` (a file or the directory itself): one CacheWarning per process naming the
    path and the reason; the kernels are then compiled in memory."""
    reason = exc if isinstance(exc, str) else (
        f"{type(exc).__name__}: {getattr(exc, 'strerror', None) or exc}")
    _DROPPED[os.path.abspath(directory)] = reason
    message = (f"the compiled-kernel cache at {path} cannot be used ({reason}); running "
               f"without it (kernels are compiled in memory)")
    if not _warn_once(message, "dropped"):
        log.info(message)


def _remove(path: str) -> None:
    """Remove a file or a directory tree at `path` (a damaged entry); silent on failure."""
    try:
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path)
        else:
            os.unlink(path)
    except OSError:
        pass


def read_entry(path: str) -> bytes | None:
    """The bytes of the cache entry `path` (as given to `write_entry`), or None: missing,
    or damaged (its digest does not match, it is not a file): then removed, with one
    CacheWarning per process naming it."""
    try:
        with open(path, "rb") as f:
            blob = f.read()
    except FileNotFoundError:
        return None
    except OSError as exc:          # a directory in its place, unreadable: damaged
        _drop_damaged(path, exc)
        return None
    head = len(ENTRY_MAGIC)
    payload = blob[head + 32:]
    if blob[:head] != ENTRY_MAGIC or hashlib.sha256(payload).digest() != blob[head:head + 32]:
        _drop_damaged(path, "its digest does not match its contents")
        return None
    return payload


def write_entry(path: str, data: bytes) -> None:
    """Write the cache entry `path` atomically (a temporary file renamed), its digest in
    front; OSError (a full disk, a read-only directory, a directory in its place) passes
    to the caller, the temporary file removed."""
    tmp = f"{path}.tmp.{uuid.uuid4().hex[:16]}"
    try:
        with open(tmp, "wb") as f:
            f.write(ENTRY_MAGIC + hashlib.sha256(data).digest())
            f.write(data)
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path)         # a directory where the entry belongs
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


# ---------------------------------------------------------------- numba's cache files

_LOAD_INDEX = caching.IndexDataCacheFile._load_index
_LOAD_DATA = caching.IndexDataCacheFile._load_data
_SAVE = caching.IndexDataCacheFile.save
_LOAD = caching.IndexDataCacheFile.load
_OURS: set[str] = set()         # the cache directories chosen by `_cache_dir`


def _is_ours(self) -> bool:
    return os.path.abspath(self._cache_path) in _OURS


def _load_index_verified(self):
    """The index of one of our directories (its digest checked before it is unpickled),
    else numba's loader (`_load_index_or_empty`)."""
    if not _is_ours(self):
        return _load_index_or_empty(self)
    payload = read_entry(self._index_path)
    if payload is None:
        return {}
    try:
        version, stamp, overloads = pickle.loads(payload)
    except (ImportError, AttributeError):
        return {}       # names a model generated on demand by another process: a miss
    if version != self._version or stamp != self._source_stamp:
        return {}
    return overloads


def _save_index_verified(self, overloads):
    if not _is_ours(self):
        return _SAVE_INDEX(self, overloads)
    write_entry(self._index_path, self._dump((self._version, self._source_stamp, overloads)))


def _load_data_verified(self, name):
    if not _is_ours(self):
        return _load_data_or_none(self, name)
    payload = read_entry(self._data_path(name))
    return None if payload is None else pickle.loads(payload)


def _save_data_verified(self, name, data):
    if not _is_ours(self):
        return _SAVE_DATA(self, name, data)
    write_entry(self._data_path(name), self._dump(data))


def _save_or_drop(self, key, data):
    """numba's save; any failure (a full disk, a read-only or damaged directory, an index
    holding kernels that no longer exist) drops the cache directory for this process with
    one warning naming the file, and the run goes on."""
    if cache_dropped(self._cache_path):
        return
    try:
        return _SAVE(self, key, data)
    except Exception as exc:  # noqa: BLE001 - a cache must never stop a run
        path = getattr(exc, "filename", None) or self._index_path
        if not isinstance(exc, OSError):
            _remove(self._index_path)   # an index that cannot be saved again: start afresh
        drop_cache(self._cache_path, str(path), exc)


def _load_or_miss(self, key):
    """numba's load; any failure reads as a miss (the kernel compiled), the cache
    directory dropped for this process with one warning naming the index."""
    if cache_dropped(self._cache_path):
        return None
    try:
        return _LOAD(self, key)
    except Exception as exc:  # noqa: BLE001 - a cache must never stop a run
        path = getattr(exc, "filename", None) or self._index_path
        drop_cache(self._cache_path, str(path), exc)
        return None


_SAVE_INDEX = caching.IndexDataCacheFile._save_index
_SAVE_DATA = caching.IndexDataCacheFile._save_data


def _load_index_or_empty(self):
    """numba's index loader; an index naming a module this process cannot import (a model
    generated on demand, loaded by another process) reads as empty (a cache miss); a
    damaged index is dropped and reads as empty."""
    try:
        return _LOAD_INDEX(self)
    except (ImportError, AttributeError):
        return {}
    except Exception as exc:  # noqa: BLE001 - any failure to unpickle: a damaged file
        _drop_damaged(self._index_path, exc)
        return {}


def _load_data_or_none(self, name):
    """numba's data loader; a damaged data file is dropped and reads as missing (None: the
    kernel is compiled again and its entry rewritten)."""
    try:
        return _LOAD_DATA(self, name)
    except OSError:
        raise                   # removed meanwhile: numba reads that as a miss itself
    except Exception as exc:  # noqa: BLE001 - any failure to unpickle: a damaged file
        _drop_damaged(self._data_path(name), exc)
        return None


def _drop_damaged(path: str, exc: Exception | str) -> None:
    """Remove the damaged cache file `path` (the next compile rewrites it) and say so: one
    CacheWarning per process, later ones at INFO."""
    _remove(path)               # removed by another process, or read-only: a miss anyway
    reason = exc if isinstance(exc, str) else f"{type(exc).__name__}: {exc}"
    message = (f"the compiled-kernel cache file {path} was damaged ({reason}); it was "
               f"dropped and its kernels are compiled again")
    if not _warn_once(message, "damaged"):
        log.info(message)


def register_package(name: str, depends_on: tuple[str, ...] = ()) -> str | None:
    """Key the numba cache of the kernels defined in package `name` (and its subpackages) by
    the digest of its sources now and of the packages `depends_on`, whose functions its
    kernels compile in; call it in the package's ``__init__`` before any kernel is defined.
    Returns the digest (None for a package that is not a directory, e.g. in a zip file:
    numba's own locators then apply)."""
    root = Path(sys.modules[name].__file__).resolve().parent
    if not root.is_dir():
        return None
    deps = []
    for dep in depends_on:
        importlib.import_module(dep)            # registers it
        deps.append(_PACKAGES[str(Path(sys.modules[dep].__file__).resolve().parent)])
    files = _source_files(root)
    signature = _stat_signature(files)
    digest = sources_digest(root, tuple(d.digest for d in deps))
    _PACKAGES[str(root)] = _Package(name, str(root), digest, tuple(deps), files, signature)
    if DigestLocator not in CacheImpl._locator_classes:
        CacheImpl._locator_classes.insert(0, DigestLocator)
    cls = caching.IndexDataCacheFile
    cls._load_index, cls._save_index = _load_index_verified, _save_index_verified
    cls._load_data, cls._save_data = _load_data_verified, _save_data_verified
    cls.save, cls.load = _save_or_drop, _load_or_miss
    global _LISTENER
    if _LISTENER is None:
        _LISTENER = CompileListener()
        numba_event.register("numba:compile", _LISTENER)
    return digest


def _package_of(py_file: str) -> _Package | None:
    path = os.path.realpath(py_file)
    for root, package in _PACKAGES.items():
        if path.startswith(root + os.sep):
            return package
    return None


def _writable(path: str) -> bool:
    try:
        os.makedirs(path, mode=0o755, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
        return True
    except OSError:
        return False


def _private_temp_root() -> str:
    """A directory of this user's own in the temporary directory: mode 0700 and owned by the
    user, else (someone else made it) a new one for this process, removed at exit. The
    cache holds pickles: a directory others can write to must never be read."""
    base = tempfile.gettempdir()
    uid = getattr(os, "getuid", lambda: None)()
    if uid is not None:
        path = os.path.join(base, f"mbs_clearance-numba-{uid}")
        try:
            os.makedirs(path, mode=0o700, exist_ok=True)
            st = os.lstat(path)
            if (stat.S_ISDIR(st.st_mode) and st.st_uid == uid
                    and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)):
                return path
        except OSError:
            pass
    path = tempfile.mkdtemp(prefix="mbs_clearance-numba-")
    atexit.register(shutil.rmtree, path, True)
    return path


def _prune(parent: str, keep: str) -> None:
    """Remove from `parent` the cache directories of other digests and the legacy files
    (numba's own *.nbi, *.nbc) unused for PRUNE_AGE seconds."""
    old = time.time() - PRUNE_AGE
    try:
        entries = list(os.scandir(parent))
    except OSError:
        return
    for entry in entries:
        try:
            if entry.name != keep and entry.stat(follow_symlinks=False).st_mtime < old:
                if entry.name.startswith(PREFIX) and entry.is_dir(follow_symlinks=False):
                    shutil.rmtree(entry.path, ignore_errors=True)
                elif entry.name.endswith(_LEGACY) and entry.is_file():
                    os.unlink(entry.path)
        except OSError:
            pass        # removed by a concurrent import, or read-only


def _warn_once(message: str, kind: str = "directory") -> bool:
    """`message` as a CacheWarning, once per process and `kind`, attributed to the first
    frame outside numba, importlib and the registered packages (the user's import or call);
    returns whether it warned."""
    if kind in _WARNED:
        return False
    _WARNED.add(kind)
    inside = (_NUMBA_DIR, *(root + os.sep for root in _PACKAGES))
    level, frame = 2, sys._getframe(1)      # stacklevel 2: the caller of this function
    while frame is not None:
        name = frame.f_code.co_filename
        if "importlib" in name and "_bootstrap" in name:
            pass                            # warnings does not count these frames
        elif name.startswith(inside):
            level += 1
        else:
            break
        frame = frame.f_back
    warnings.warn(message, CacheWarning, stacklevel=level)
    return True


def _cache_dir(package: _Package, py_file: str) -> str | None:
    """The cache directory of the kernels in `py_file`, chosen once per source directory and
    digest: the first writable of NUMBA_CACHE_DIR, __pycache__, numba's user cache, else a
    private temporary directory (with the warning)."""
    source_dir = os.path.dirname(os.path.realpath(py_file))
    name = PREFIX + package.digest[:12]
    if (source_dir, name) in _DIRS:
        return _DIRS[source_dir, name]
    subpath = _CacheLocator.get_suitable_cache_subpath(py_file)
    user = AppDirs(appname="numba", appauthor=False).user_cache_dir
    candidates = [(os.path.join(source_dir, "__pycache__"), name),
                  (user, os.path.join(subpath, name))]
    if config.CACHE_DIR:
        candidates.insert(0, (config.CACHE_DIR, os.path.join(subpath, name)))
    chosen = None
    for root, rest in candidates:
        path = os.path.join(root, rest)
        if not _writable(path):
            continue
        reason = untrusted(path, root)
        if reason is None:
            chosen = path
            break
        _warn_once(f"the compiled-kernel cache directory {path} is not used: {reason} "
                   f"(a cache others can write to is never read)", "untrusted")
    if chosen is None:
        try:
            chosen = os.path.join(_private_temp_root(), subpath, name)
            os.makedirs(chosen, exist_ok=True)
            _warn_once(f"no writable cache directory for the compiled kernels of "
                       f"{package.name} (read-only install and home); caching them in "
                       f"{os.path.dirname(os.path.dirname(chosen))} (set NUMBA_CACHE_DIR to "
                       f"choose the place)")
        except OSError as err:  # no temporary directory either: numba's error follows
            _warn_once(f"no writable directory for the compiled kernels of {package.name} "
                       f"({err}); set NUMBA_CACHE_DIR to a writable directory")
            chosen = None
    if chosen is not None:
        _prune(os.path.dirname(chosen), name)
        _OURS.add(os.path.abspath(chosen))
    _DIRS[source_dir, name] = chosen
    return chosen


class DigestLocator(_CacheLocator):
    """numba cache locator for the kernels of the registered packages (module docstring)."""

    def __init__(self, py_func, py_file, path, stamp):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._path = path
        self._stamp = stamp

    def get_cache_path(self):
        return self._path

    def get_source_stamp(self):
        return self._stamp

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        package = _package_of(py_file)
        if package is None:
            return None             # not ours: numba's locators
        path = _cache_dir(package, py_file)
        if path is None:
            return None
        stamp = package.digest if package.unchanged() else f"changed-{uuid.uuid4().hex}"
        return cls(py_func, py_file, path, stamp)
