"""Build C sources into a shared library once, cache it under a digest, load it with cffi.

A library is named by the SHA-256 of everything that makes it: its sources, the header, the
compiler's identity and the flags. It is built with the system's C compiler (``$CC``, else
``gcc``, else ``cc``) into the first trusted directory of ``$MBS_CLEARANCE_CACHE_DIR``,
``$XDG_CACHE_HOME/mbs-clearance/core`` (``~/.cache/...``) and a private directory in the
temporary directory. A library is code this process runs, so (as for generated models):

- a directory is used only if the user owns it and neither group nor others can write to it;
- a library is loaded only if its bytes match the SHA-256 recorded beside it when it was
  built; a damaged, stale or foreign file is built again, with one `CacheWarning`;
- a directory that cannot be written (read-only, full) is skipped with one warning naming
  it, and the next place is tried.

Loading goes through cffi's ABI mode (``ffi.dlopen``): cffi releases the GIL around every call,
so threads run models in parallel.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import stat
import subprocess
import tempfile
import threading
import time
import warnings
from pathlib import Path

from .._warnings import CacheWarning

__all__ = ["HEADER", "FLAGS", "CompilerMissing", "cdef_of", "compiler", "build", "load",
           "cache_dirs", "usable", "valid", "stamp", "compile_count", "used_files", "install"]

_HERE = Path(__file__).resolve().parent
#: the seam's header (its declarations are the cffi cdef of every library)
HEADER = _HERE / "mbs_core.h"
#: C99, optimised, IEEE semantics kept (no -ffast-math: event search and error control rely
#: on them), position independent for a shared library
FLAGS = ("-std=c99", "-O2", "-fPIC", "-shared", "-fno-math-errno")
_LOG = logging.getLogger("mbs_clearance")
_LOCK = threading.Lock()
_LOADED: dict[str, object] = {}
_WARNED: set[str] = set()
#: libraries compiled by this process; cache files it used (name -> path), which
#: `used_files` hands to other processes (dask workers) so that they compile nothing
_COMPILED = [0]
_USED: dict[str, Path] = {}


class CompilerMissing(RuntimeError):
    """No C compiler on this machine (the message names what to install)."""


def cdef_of(header: Path = HEADER) -> str:
    """The declarations of `header` for cffi: preprocessor lines dropped."""
    lines = header.read_text().splitlines()
    return "\n".join(line for line in lines if not line.lstrip().startswith("#"))


def compiler() -> tuple[str, str]:
    """(path, identity) of the C compiler: ``$CC``, gcc or cc; identity is its
    ``--version`` first line (part of every library's digest)."""
    names = [os.environ["CC"]] if os.environ.get("CC") else ["gcc", "cc"]
    for name in names:
        path = shutil.which(name)
        if path:
            try:
                version = subprocess.run([path, "--version"], capture_output=True, text=True,
                                         timeout=30).stdout.splitlines()[:1]
            except (OSError, subprocess.SubprocessError):
                continue
            return path, (version[0] if version else path)
    raise CompilerMissing(
        f"no C compiler found (looked for {', '.join(names)}): mbs-clearance compiles its "
        "core and models with one; install gcc (Debian/Ubuntu: apt-get install gcc; "
        "Fedora: dnf install gcc; macOS: xcode-select --install)")


def _trusted(path: Path) -> bool:
    """Owned by this user, a real directory, writable by neither group nor others."""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    uid = getattr(os, "getuid", lambda: st.st_uid)()
    return (stat.S_ISDIR(st.st_mode) and st.st_uid == uid
            and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH))


def _warn_once(key: str, message: str) -> None:
    if key not in _WARNED:
        _WARNED.add(key)
        warnings.warn(message, CacheWarning, stacklevel=4)


def cache_dirs() -> list[Path]:
    """The candidate cache directories, in order of preference."""
    dirs = []
    if os.environ.get("MBS_CLEARANCE_CACHE_DIR"):
        dirs.append(Path(os.environ["MBS_CLEARANCE_CACHE_DIR"]))
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    dirs.append(Path(base) / "mbs-clearance" / "core")
    uid = getattr(os, "getuid", lambda: "user")()
    dirs.append(Path(tempfile.gettempdir()) / f"mbs-clearance-core-{uid}")
    return dirs


def _usable(path: Path) -> bool:
    """Create `path` (mode 0700) if missing; True when it is trusted and writable."""
    try:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError:
        return False
    if not _trusted(path):
        _warn_once(str(path), f"the compiled-code cache directory {path} is not used: it is "
                              "not owned by this user or others can write to it")
        return False
    return os.access(path, os.W_OK)


def _digest(sources: list[tuple[str, str]], flags: tuple[str, ...], cc_id: str) -> str:
    h = hashlib.sha256()
    for name, text in [("mbs_core.h", HEADER.read_text()), *sources]:
        h.update(name.encode() + b"\0" + text.encode() + b"\0")
    h.update("\0".join(flags).encode() + b"\0" + cc_id.encode())
    return h.hexdigest()


def _sha_file(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _valid(lib: Path) -> bool:
    stamp = lib.with_suffix(".sha256")
    try:
        st = os.lstat(lib)
        if not stat.S_ISREG(st.st_mode) or st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            return False
        return stamp.read_text().strip() == _sha_file(lib)
    except OSError:
        return False


def _compile(cc: str, sources: list[tuple[str, str]], flags: tuple[str, ...], lib: Path,
             label: str) -> None:
    """Compile into `lib` atomically (a temporary name in the same directory, then rename)."""
    with tempfile.TemporaryDirectory(prefix="mbs-build-") as tmp:
        paths = []
        shutil.copy(HEADER, Path(tmp) / HEADER.name)
        for name, text in sources:
            path = Path(tmp) / name
            path.write_text(text)
            if name.endswith(".c"):
                paths.append(str(path))
        out = Path(tmp) / "lib.so"
        estimate = _last_seconds(lib.parent, label)
        if estimate is None or estimate > 1.0:
            _LOG.info("compiling %s (first use only%s)", label,
                      "" if estimate is None else f", about {estimate:.0f} s")
        started = time.perf_counter()
        proc = subprocess.run([cc, *flags, "-I", tmp, "-o", str(out), *paths, "-lm"],
                              capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"compiling {label} failed ({cc}):\n{proc.stderr.strip()}")
        seconds = time.perf_counter() - started
        _LOG.debug("compiled %s in %.2f s", label, seconds)
        _note_seconds(lib.parent, label, seconds)
        part = lib.with_name(f"{lib.name}.part-{os.getpid()}-{threading.get_ident()}")
        shutil.copy(out, part)
        os.chmod(part, 0o700)
        lib.with_suffix(".sha256").write_text(_sha_file(part) + "\n")
        os.replace(part, lib)


def _seconds_file(directory: Path, label: str) -> Path:
    return directory / f"{label.split('-')[0]}.seconds"


def _last_seconds(directory: Path, label: str) -> float | None:
    """The last compile time of a library of this kind (the label's first word), if any."""
    try:
        return float(_seconds_file(directory, label).read_text())
    except (OSError, ValueError):
        return None


def _note_seconds(directory: Path, label: str, seconds: float) -> None:
    try:
        _seconds_file(directory, label).write_text(f"{seconds:.3f}\n")
    except OSError:
        pass            # only an estimate for the next message


def build(label: str, sources, flags: tuple[str, ...] = FLAGS, key: str | None = None) -> Path:
    """The path of the shared library built from `sources` ((file name, text) pairs, C files
    and headers), built now if no valid cached copy exists. `label` names it in messages.

    With `key` (a text that determines the sources, e.g. a model's structure and the
    generator's digest) the library is found by that key, and `sources` may be a callable
    that makes them, called only when the library must be built (a generated model's
    derivation is skipped when its library is cached)."""
    cc, cc_id = compiler()
    if key is None:
        digest = _digest(sources, flags, cc_id)
    else:
        digest = _digest([("key", key)], flags, cc_id)
    name = f"{label}-{digest[:24]}.so"
    last_error = None
    for directory in cache_dirs():
        if not _usable(directory):
            continue
        lib = directory / name
        if _valid(lib):
            _USED[name] = lib
            return lib
        if lib.exists():
            _warn_once(str(lib), f"the compiled library {lib} does not match its recorded "
                                 "digest (damaged or changed); it is built again")
        if callable(sources):
            sources = sources()
        try:
            _compile(cc, sources, flags, lib, label)
            _COMPILED[0] += 1
            _USED[name] = lib
            return lib
        except OSError as err:       # full or read-only: the next place
            last_error = err
            _warn_once(str(directory), f"the compiled-code cache directory {directory} "
                                       f"cannot be written ({err.strerror}); trying the next")
    raise RuntimeError(f"no writable place to build {label}: set MBS_CLEARANCE_CACHE_DIR to a "
                       f"writable directory of your own ({last_error})")


def load(label: str, sources, cdef: str = "", flags: tuple[str, ...] = FLAGS,
         key: str | None = None):
    """(ffi, lib): the library of `sources` built (or found) and opened with cffi; `cdef`
    adds declarations to the seam's header; `key`: as for `build`. One load per library and
    process."""
    import cffi

    with _LOCK:
        path = build(label, sources, flags, key)
        key = str(path)
        if key not in _LOADED:
            ffi = cffi.FFI()
            ffi.cdef(cdef_of() + "\n" + cdef)
            _LOADED[key] = (ffi, ffi.dlopen(key))
        return _LOADED[key]


def usable(path: Path) -> bool:
    """Whether `path` is a cache directory this process may use (created if missing: mode
    0700, owned by this user, writable by neither group nor others, writable)."""
    return _usable(path)


def valid(path: Path) -> bool:
    """Whether the file `path` is regular, writable by neither group nor others, and its
    SHA-256 is the one recorded beside it (`stamp`). A valid cache file counts as used
    (`used_files`)."""
    ok = _valid(path)
    if ok:
        _USED[path.name] = path
    return ok


def compile_count() -> int:
    """Libraries this process has compiled (a count: what a worker that was handed them
    should never do)."""
    return _COMPILED[0]


def used_files() -> dict[str, tuple[bytes, str]]:
    """The cache files (libraries, generated sources) this process has used, by name, with
    their SHA-256: what another process on a machine like this one needs to compile nothing
    (`install`)."""
    out = {}
    for name, path in list(_USED.items()):
        try:
            data = path.read_bytes()
        except OSError:
            continue
        out[name] = (data, hashlib.sha256(data).hexdigest())
    return out


def install(files: dict[str, tuple[bytes, str]]) -> int:
    """Put `files` (`used_files` of another process) into this process's first usable
    cache directory, each checked against its SHA-256 first (a file that does not match is
    left out) and stamped as a built one is; files already there and valid are kept.
    Returns the number written. The libraries are found by the same digest as a build here
    (same sources, compiler and flags), so they serve processes with the same compiler."""
    for directory in cache_dirs():
        if not _usable(directory):
            continue
        written = 0
        for name, (data, sha) in files.items():
            target = directory / Path(name).name
            if hashlib.sha256(data).hexdigest() != sha or _valid(target):
                continue
            part = target.with_name(f"{target.name}.part-{os.getpid()}-{threading.get_ident()}")
            try:
                part.write_bytes(data)
                os.chmod(part, 0o700 if name.endswith(".so") else 0o600)
                stamp(part, target)
                written += 1
            except OSError:
                part.unlink(missing_ok=True)
        return written
    return 0


def stamp(part: Path, path: Path) -> None:
    """Record the SHA-256 of the finished file `part` beside `path`, then move it there
    (atomically: a reader sees the old file or the new one)."""
    path.with_suffix(".sha256").write_text(_sha_file(part) + "\n")
    os.replace(part, path)
