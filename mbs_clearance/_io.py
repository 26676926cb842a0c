"""File helpers shared by the result types and the command line: readable errors instead of
tracebacks, output paths checked before any computation, results written atomically.

Output policy (command line):

- A **single output file** (a trajectory, a figure, a JSON summary) is written to a temporary
  file beside it and renamed into place, so it is either the old file or the complete new one.
  An existing file is overwritten only when an earlier run of this program wrote it (a
  trajectory that loads, a PNG whose ``Software`` field names mbs-clearance, a JSON file with
  an ``mbs_clearance_run`` key); any other file needs ``--force``.
- An **output folder** (several files of one run) is built in a hidden folder beside it
  (``.NAME.partial-PID-RUNID``) and moved into place at the end, with a ``manifest.json`` that
  stamps every file with the run id and its SHA-256. An interrupted run leaves the previous
  folder as it was. An existing folder is replaced only when it is empty or when it holds
  exactly the files its manifest lists; anything else needs ``--force``.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import secrets
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

MANIFEST = "manifest.json"
TOOL = "mbs-clearance"
#: key of the run stamp in JSON files written by the command line
RUN_KEY = "mbs_clearance_run"
#: PNG metadata of the figures (matplotlib ``metadata=``), how our figures are recognised
PNG_SOFTWARE = "mbs-clearance"


#: the largest input file (description, configuration, inputs) read, in bytes
MAX_INPUT_BYTES = 4 * 1024 * 1024


def read_text(path: str | Path, what: str, limit: int = MAX_INPUT_BYTES) -> str:
    """The text (UTF-8) of the input file `path`, read up to `limit` bytes; ValueError naming
    `what` and the file if it cannot be read, is not UTF-8 or is larger (a device such as
    /dev/zero included: never read to its end)."""
    try:
        with open(path, "rb") as fh:
            data = fh.read(limit + 1)
    except OSError as exc:
        raise ValueError(f"cannot read {what} {str(path)!r}: {exc.strerror or exc}") from None
    if len(data) > limit:
        raise ValueError(f"{what} {str(path)!r} is larger than {limit // 1024} KiB ({limit} "
                         f"bytes), the most an input file may hold")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"cannot read {what} {str(path)!r}: not UTF-8 text ({exc.reason} "
                         f"at byte {exc.start})") from None


def parse_json(text: str, path: str | Path, what: str) -> Any:
    """`text` parsed as JSON; ValueError naming `what` and the file if it is not JSON (or
    nested too deeply to parse)."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"cannot read {what} {str(path)!r}: {exc}") from None
    except RecursionError:
        raise ValueError(f"cannot read {what} {str(path)!r}: nested too deeply") from None


def read_json_object(path: str | Path, what: str) -> dict[str, Any]:
    """The JSON object in `path`; ValueError naming `what` and the file if it cannot be read,
    is larger than MAX_INPUT_BYTES or is not an object."""
    data = parse_json(read_text(path, what), path, what)
    if not isinstance(data, dict):
        raise ValueError(f"{what} {str(path)!r} must hold a JSON object")
    return data


def write_json_object(path: str | Path, data: dict[str, Any]) -> Path:
    """Write `data` as indented JSON to `path` (its folder made if missing); returns the
    path. The one writer of the results' JSON files (`read_json_object` reads them)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2))
    return path


def new_run_id() -> str:
    """A run id: UTC time, process id and a random tag (unique across concurrent runs)."""
    return f"{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}-{os.getpid()}-{secrets.token_hex(3)}"


def run_stamp(command: str, run_id: str | None = None) -> dict[str, str]:
    """The stamp stored in a run's JSON files and manifest."""
    return {"tool": TOOL, "command": command, "run_id": run_id or new_run_id(),
            "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}


# ------------------------------------------------------------------ checks before computing
def _nearest_existing(path: Path) -> Path:
    """The nearest existing ancestor of `path`, spelled as the user gave it."""
    p = path
    while not os.path.lexists(p) and p != p.parent:
        p = p.parent
    return p


def check_can_create_in(path: Path, option: str, what: str) -> None:
    """ValueError naming `option` unless the folder that will hold `path` exists or can be
    created, and is writable (a real probe: a temporary folder is made and removed)."""
    anchor = _nearest_existing(path.parent)
    if not anchor.is_dir():
        raise ValueError(f"{option}: cannot create {what} {str(path)!r}: {str(anchor)!r} is a "
                         f"file, not a folder")
    try:  # a real probe: os.access ignores read-only mounts for root and some file systems
        probe = tempfile.mkdtemp(prefix=".mbs-clearance-probe-", dir=anchor)
    except OSError as exc:
        raise ValueError(f"{option}: cannot write {what} {str(path)!r}: folder "
                         f"{str(anchor)!r} is not writable (creating a file there fails: "
                         f"{exc.strerror or exc})") from exc
    os.rmdir(probe)
    check_free_space(anchor, option, what, path)


#: the least free space in bytes a folder must have for a command's output: the largest
#: output written (figures, trajectories, a map) takes a few MiB
MIN_FREE_BYTES = 16 * 1024**2


def check_free_space(folder: Path, option: str, what: str, path: Path) -> None:
    """ValueError naming `option` where the file system holding `folder` has less than
    `MIN_FREE_BYTES` free (a full disk found before the work, not after it)."""
    try:
        st = os.statvfs(folder)
    except (AttributeError, OSError):
        return                              # not measurable here: the writes will tell
    free = st.f_bavail * st.f_frsize
    if free < MIN_FREE_BYTES:
        raise ValueError(f"{option}: cannot write {what} {str(path)!r}: the disk holding "
                         f"{str(folder)!r} has {free // 1024} KiB free, less than "
                         f"{MIN_FREE_BYTES // 1024**2} MiB (full disk)")


def _png_is_ours(path: Path) -> bool:
    """True if `path` is a PNG whose tEXt ``Software`` chunk names mbs-clearance."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
    except OSError:
        return False
    return head.startswith(b"\x89PNG") and b"Software\x00" + PNG_SOFTWARE.encode() in head


def file_is_ours(path: str | Path, reader: Callable[[Path], Any] | None = None) -> bool:
    """True if `path` was written by this program (see the module docstring). A data file
    (``.npz``, ``.csv``, ``.nc``) is ours when `reader`, the loader of the result type it holds,
    reads it without error (no reader: not ours)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".png":
        return _png_is_ours(path)
    if suffix in (".npz", ".csv", ".nc"):
        if reader is None:
            return False
        try:
            reader(path)
        except Exception:  # noqa: BLE001 - anything unreadable is not ours
            return False
        return True
    if suffix == ".json":
        try:
            data = parse_json(read_text(path, "file"), path, "file")
        except ValueError:
            return False
        return isinstance(data, dict) and isinstance(data.get(RUN_KEY), dict)
    return False


def check_output_file(path: str | Path, option: str, force: bool = False,
                      suffixes: tuple[str, ...] | None = None,
                      reader: Callable[[Path], Any] | None = None) -> Path:
    """Check an output file before computing: ValueError naming `option` and the file if it
    cannot be written, is a folder, has a wrong suffix or would overwrite a file this program
    did not write (unless `force`; `reader`: the loader that recognises our data files, see
    `file_is_ours`)."""
    path = Path(path)
    recover(path)
    if suffixes is not None and path.suffix.lower() not in suffixes:
        allowed = (" or ".join(suffixes) if len(suffixes) <= 3 else
                   f"a known format ({', '.join(suffixes[:3])}, ...; {len(suffixes)} in all)")
        raise ValueError(f"{option} must end in {allowed}; got {str(path)!r}")
    if path.is_dir():
        raise ValueError(f"{option} {str(path)!r} is a folder; expected a file name")
    check_can_create_in(path, option, "file")
    if os.path.lexists(path):
        if not path.is_file():
            raise ValueError(f"{option} {str(path)!r} exists and is not a regular file")
        if not os.access(path, os.W_OK):
            raise ValueError(f"{option}: file {str(path)!r} is not writable")
        if not file_is_ours(path, reader):
            if not force:
                raise ValueError(f"{option} {str(path)!r} exists and was not written by "
                                 f"mbs-clearance; choose another name or pass --force to "
                                 f"overwrite it")
            _note(f"{option}: {str(path)!r} was not written by mbs-clearance; it will be "
                  f"overwritten (--force)")
    return path


def _note(message: str) -> None:
    import logging

    logging.getLogger("mbs_clearance").warning(f"note: {message}")


def read_manifest(folder: Path) -> dict[str, Any] | None:
    """The manifest of a run folder, or None if there is none or it is not ours."""
    try:
        path = folder / MANIFEST
        data = parse_json(read_text(path, "manifest"), path, "manifest")
    except ValueError:
        return None
    if not (isinstance(data, dict) and data.get("tool") == TOOL
            and isinstance(data.get("files"), dict) and isinstance(data.get("run_id"), str)):
        return None
    return data


def _listing(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*")
                  if not p.is_dir())


def check_output_dir(path: str | Path, option: str, force: bool = False,
                     resume: dict[str, Callable[[Path], Any]] | None = None) -> Path:
    """Check an output folder before computing: ValueError naming `option` if it is a file,
    cannot be created or written, or holds files no run of this program wrote (unless
    `force`). `resume` names the files of an unfinished run that the command resumes from,
    each with the loader that recognises it: such a file counts as this program's even
    without a manifest."""
    path = Path(path)
    recover(path)
    for name in resume or {}:       # temporary files of a killed run's resumable files
        recover(path / name)
    if os.path.lexists(path) and not path.is_dir():
        raise ValueError(f"{option} {str(path)!r} is a file; expected a folder")
    check_can_create_in(path, option, "folder")
    if path.is_dir():
        resumable = {name for name, reader in (resume or {}).items()
                     if (path / name).is_file() and file_is_ours(path / name, reader)}
        files = [f for f in _listing(path) if f not in resumable]
        manifest = read_manifest(path) if files else None
        foreign = [f for f in files if manifest is None or
                   (f != MANIFEST and f not in manifest["files"])]
        if foreign and force:
            _note(f"{option}: folder {str(path)!r} holds files mbs-clearance did not write "
                  f"(e.g. {foreign[0]!r}); it will be replaced (--force)")
        elif files:
            damaged = [name for name in resume or {} if name in files]
            if manifest is None and damaged:
                raise ValueError(f"{option} {str(path)!r} holds {damaged[0]!r}, which cannot "
                                 f"be resumed: damaged (e.g. by an interrupted write) or a "
                                 f"file mbs-clearance did not write; remove "
                                 f"{str(path / damaged[0])!r} to start afresh, or pass --force "
                                 f"to replace the folder")
            if manifest is None:
                raise ValueError(f"{option} {str(path)!r} is a non-empty folder that "
                                 f"mbs-clearance did not write (no {MANIFEST}); choose "
                                 f"another folder or pass --force to replace it")
            foreign = [f for f in files if f != MANIFEST and f not in manifest["files"]]
            if foreign:
                raise ValueError(f"{option} {str(path)!r} holds {foreign[0]!r}, which no "
                                 f"mbs-clearance run wrote; move it or pass --force to "
                                 f"replace the folder")
    return path


@contextlib.contextmanager
def folder_lock(path: str | Path, option: str) -> Iterator[Path]:
    """Create the folder `path` if needed and hold an exclusive lock on it while the body
    runs: a second run writing into the same folder is refused at once (ValueError naming
    `option`) instead of mixing its files into this one's. The lock is the kernel's
    (flock on the folder itself): it ends with the process, however that ends."""
    import fcntl

    path = Path(path)
    created = not os.path.lexists(path)
    path.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise ValueError(f"{option} {str(path)!r} is in use by another mbs-clearance "
                             "run; wait for it to end or choose another folder") from None
        yield path
    except BaseException:
        if created:             # a run that failed before writing leaves nothing behind
            with contextlib.suppress(OSError):
                path.rmdir()
        raise
    finally:
        os.close(fd)


def verify_run_folder(path: str | Path) -> dict[str, Any]:
    """The manifest of a complete run folder; ValueError if it is missing or any file differs
    from the run the manifest describes (missing, changed, or not listed)."""
    path = Path(path)
    manifest = read_manifest(path)
    if manifest is None:
        raise ValueError(f"{str(path)!r} holds no complete run ({MANIFEST} missing or not "
                         f"written by mbs-clearance)")
    run = manifest["run_id"]
    for name, digest in manifest["files"].items():
        f = path / name
        if not f.is_file():
            raise ValueError(f"{str(path)!r} is incomplete: {name} of run {run} is missing")
        if sha256(f) != digest:
            raise ValueError(f"{str(path)!r} mixes runs: {name} is not the file of run {run} "
                             f"(its contents changed since that run)")
    extra = [f for f in _listing(path) if f != MANIFEST and f not in manifest["files"]]
    if extra:
        raise ValueError(f"{str(path)!r} mixes runs: {extra[0]} is not part of run {run}")
    return manifest


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


# ------------------------------------------------------------------ atomic writes
def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _siblings(target: Path, kind: str) -> list[tuple[Path, int]]:
    """Hidden work folders of `target` (kind "partial" or "old") with the pid that made them."""
    out = []
    parent = target.absolute().parent
    if not parent.is_dir():
        return out
    for p in parent.glob(f".{target.name}.{kind}-*"):
        try:
            pid = int(p.name[len(f".{target.name}.{kind}-"):].split("-", 1)[0])
        except ValueError:
            continue
        out.append((p, pid))
    return out


def recover(target: str | Path) -> None:
    """Clean up after runs that were killed: delete their partial files and folders and, if
    a kill came between the two renames of `OutputDir.commit`, put the previous run back."""
    target = Path(target)
    for p, pid in _siblings(target, "partial"):
        if not _pid_alive(pid):
            _remove(p)
    for p, pid in _siblings(target, "old"):
        if _pid_alive(pid):
            continue
        if not os.path.lexists(target):
            os.rename(p, target)
        else:
            _remove(p)


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(OSError):
            path.unlink()


class OutputDir:
    """A run's output folder, built in a hidden folder beside `target` and moved into place
    by `commit` (with a manifest stamping every file with the run id). Use as a context
    manager: on an exception the partial folder is deleted and `target` is left as it was.
    """

    def __init__(self, target: str | Path, command: str, run_id: str | None = None):
        self.target = Path(target)
        self.stamp = run_stamp(command, run_id)
        self.run_id = self.stamp["run_id"]
        self.path: Path | None = None

    def __enter__(self) -> OutputDir:
        parent = self.target.absolute().parent
        parent.mkdir(parents=True, exist_ok=True)
        self.path = parent / f".{self.target.name}.partial-{self.run_id.split('-', 1)[1]}"
        self.path.mkdir()
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if self.path is not None and self.path.exists():
            shutil.rmtree(self.path, ignore_errors=True)
        if isinstance(exc, OSError) and exc.filename is None and exc.strerror:
            # a write that failed (a full disk): say which output it was
            raise OSError(exc.errno, exc.strerror, str(self.target)) from exc

    def commit(self, **extra: Any) -> Path:
        """Write the manifest and move the folder into place; returns `target`."""
        assert self.path is not None, "use OutputDir as a context manager"
        files = {f: sha256(self.path / f) for f in _listing(self.path)}
        manifest = {**self.stamp, **extra, "files": files}
        (self.path / MANIFEST).write_text(json.dumps(manifest, indent=1))
        # another run may commit into the same target at the same moment: whichever renames
        # last wins, and the folder is always one complete run
        for attempt in range(8):
            old = None
            if os.path.lexists(self.target):
                old = self.target.absolute().parent / (
                    f".{self.target.name}.old-{self.run_id.split('-', 1)[1]}-{attempt}")
                try:
                    os.rename(self.target, old)
                except FileNotFoundError:       # the other run moved it meanwhile
                    old = None
            try:
                os.rename(self.path, self.target)
            except OSError as exc:
                if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST) or attempt == 7:
                    raise
                if old is not None:
                    _remove(old)
                continue
            break
        self.path = None
        if old is not None:
            _remove(old)
        return self.target


@contextlib.contextmanager
def atomic_file(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside `path` (same suffix); on success it replaces `path`."""
    path = Path(path)
    path.absolute().parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.partial-{os.getpid()}-",
                               suffix=path.suffix, dir=path.absolute().parent)
    os.close(fd)
    tmp = Path(tmp)
    umask = os.umask(0)
    os.umask(umask)
    try:
        try:
            yield tmp
            os.chmod(tmp, 0o666 & ~umask)   # mkstemp makes it private; the usual mode
            os.replace(tmp, path)
        except OSError as exc:
            if exc.strerror and exc.filename in (None, str(tmp)):
                # a write that failed (a full disk): name the output, not the temporary
                raise OSError(exc.errno, exc.strerror, str(path)) from exc
            raise
    finally:
        if tmp.exists():
            tmp.unlink()
