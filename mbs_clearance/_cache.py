"""Keep numba's on-disk cache of the compiled kernels consistent with their sources.

numba keys a cached function by the timestamp of its *own* source file only. The compiled
integrator of the reduced model (`reduced.integrate_plain`, in reduced.py) contains code
from integrator.py, _trig.py and the model's kernels, so after an edit of one of those
files numba would keep loading the old machine code and the package would silently compute
with the old kernels (it happened during development). On import, `refresh_stale_cache`
compares a digest of all the package's sources with the one stored beside the cache and
removes the package's cache files when they differ; the kernels are then compiled once
more. An installed release whose files do not change never pays for it.

Where the package directory is not writable, numba caches elsewhere (or not at all; see
NUMBA_CACHE_DIR) and this check does nothing.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent
#: file beside numba's cache files holding the digest of the sources they were compiled from
STAMP = "mbs_clearance_sources.sha256"


def sources_digest(package: Path = _PACKAGE) -> str:
    """SHA-256 over the package's Python sources (names and contents, sorted by name)."""
    h = hashlib.sha256()
    for path in sorted(package.glob("*.py")):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def refresh_stale_cache(package: Path = _PACKAGE) -> bool:
    """Remove numba's cache files (*.nbi, *.nbc in package/__pycache__) if they may have been
    compiled from other sources than the current ones; returns True if it removed any."""
    cache = package / "__pycache__"
    digest = sources_digest(package)
    stamp = cache / STAMP
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass            # no stamp yet: the cache's origin is unknown
    removed = False
    for path in list(cache.glob("*.nbi")) + list(cache.glob("*.nbc")):
        try:
            path.unlink()
            removed = True
        except OSError:
            pass        # removed by a concurrent import, or read-only
    try:
        cache.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:
        pass
    return removed
